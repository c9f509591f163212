"""The REST service the MES calls: the FastAPI app, its routes, keys, problems and schemas."""
