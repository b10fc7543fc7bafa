"""Two results compared (``lgvtool compare A B``): two ``audit.json`` or two evaluation
documents (``table1.json``), KPI by KPI, with the gate of ``evaluate --baseline``
(:mod:`lgvtool.compare.result_comparison`). Pure: documents in, rows and checks out."""
