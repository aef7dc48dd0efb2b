"""What the use cases read.

Report cycles and their checks, a series and its logs, the smoothing history, the history store
a command uses, and thermal files.
"""
