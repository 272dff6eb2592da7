"""The ``contactrig`` command line: one thin layer over functions a notebook can call (see ``main``)."""
