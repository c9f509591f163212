"""The ``rcb`` command line: one module per command group, thin over services/ and supervisor/."""
