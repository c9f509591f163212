"""``GET /health``: liveness, no key needed."""

from api.rest.routes.common import resource_router
from api.rest.schemas.service import Health

router = resource_router("service")


@router.get("/health", response_model=Health, operation_id="getHealth")
def health() -> dict[str, str]:
    """Liveness; no key needed."""
    return {"status": "ok"}
