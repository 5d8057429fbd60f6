"""Research studies run on RallySim: not part of the installed package (see README.md here).

Run them from the repository's root as modules, ``python -m experiments.NAME ...``, so that
they can import each other and the library."""
