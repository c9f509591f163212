"""Use cases behind the REST service and the CLI: reads (queries) and writes (commands)."""
