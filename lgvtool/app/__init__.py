"""The application layer: every operation a command runs, as a typed function.

``lgvtool.commands`` only parses options, calls one function here and prints or writes what it
returns; Python users and Dask tasks call the same functions. Each module holds one operation
and is named after it (``<verb>_job``); docs/contracts.md lists their signatures and results.
Nothing here imports ``lgvtool.commands``.
"""
