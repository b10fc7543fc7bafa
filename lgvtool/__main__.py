"""``python -m lgvtool`` runs the command line."""

from lgvtool.cli import main

if __name__ == "__main__":
    main()
