"""The REST API's routers, one module per resource."""

from . import (
           auth,
           evaluations,
           info,
           jobs,
           members,
           models,
           plans,
           projects,
           reality,
           schedules,
           shared,
           shared_view,
           site,
           viewer,
)

ROUTERS = [info.router, projects.router, models.router, plans.router, evaluations.router, jobs.router,
           auth.router, members.router, schedules.router, reality.router, shared.router, shared_view.router, site.router,
           viewer.router]
