"""sightplan's web server: a REST API over the library, with a database and a background worker.

``sightplan.web.app.create_app`` builds the FastAPI application; ``sightplan serve`` runs it with uvicorn.
"""
