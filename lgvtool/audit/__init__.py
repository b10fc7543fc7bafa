"""The site audit: reflector layout checks, coverage along the drive, and their report."""
