"""The benches: scripts that time the package and measure what it finds, for the numbers in the docs.

Each module is one bench.  Run it from the repository root as a module, for example::

    python -m bench.cli_startup
    python -m bench.exact_scaling --seeds 2 --long 0

``python -m bench.NAME --help`` lists a bench's options.  A bench writes its result, with the command that
made it, to ``bench/results/`` (most take ``--out`` for another file).  Times are stated as ratios to a
reference timed in the same run.

The problems and reports that several benches solve are made in :mod:`bench.problems` (optimisation) and
:mod:`bench.diagnosis` (the diagnosis's series and the NIST plate).  Importing a bench runs nothing.
"""
