"""``GET /health``: liveness, no key needed; ``GET /ready``: the database takes writes now."""

from api.rest.deps import EngineDep
from api.rest.routes.common import resource_router
from api.rest.schemas.service import Health, Ready
from api.services.readiness import ready

router = resource_router("service")


@router.get("/health", response_model=Health, operation_id="getHealth")
def health() -> dict[str, str]:
    """Liveness: the process answers; no key needed, no database read."""
    return {"status": "ok"}


@router.get("/ready", response_model=Ready, operation_id="getReady")
def readiness(engine: EngineDep) -> dict[str, str]:
    """Readiness: the database would take a part report now; no key needed.

    503 ``database_busy`` with ``Retry-After`` when it cannot within 1 s
    (``api.services.readiness.READY_WAIT_MS``): locked by another writer, out of connections,
    unreachable. Nothing is written.
    """
    return ready(engine)
