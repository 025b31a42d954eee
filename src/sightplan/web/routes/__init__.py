"""The REST API's routers, one module per resource."""

from . import evaluations, info, jobs, models, plans, projects

ROUTERS = [info.router, projects.router, models.router, plans.router, evaluations.router, jobs.router]
