"""Dependencies shared by the routes (FastAPI ``Annotated`` aliases)."""

from __future__ import annotations

import hashlib
import hmac
import re
from typing import Annotated

from fastapi import Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy.orm import Session

from ..core import crud, db
from ..core.config import Settings, get_settings
from ..core.models import Job
from ..storage import Storage, get_storage

JOB_ID = re.compile(r"[0-9a-f]{32}")  # uuid4().hex
SettingsDep = Annotated[Settings, Depends(get_settings)]


def storage_of(settings: SettingsDep) -> Storage:
    return get_storage(settings)


StorageDep = Annotated[Storage, Depends(storage_of)]


def get_session(settings: SettingsDep):
    """A session for the request; it holds a pooled connection only inside each
    :mod:`~texbake.service.core.crud` call, never between them."""
    with db.sessions(settings.database)() as session:
        yield session


SessionDep = Annotated[Session, Depends(get_session)]


bearer = HTTPBearer(auto_error=False, description="an API key from BAKE_API_KEYS (only where the server has keys)")


def client_id(request: Request, settings: SettingsDep,
              credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)] = None) -> str:
    """Who is asking: the API key when keys are configured (then required), else the host."""
    if settings.api_keys:
        token = credentials.credentials if credentials else ""
        if not any(hmac.compare_digest(token.encode(), key.encode()) for key in settings.api_keys):
            raise HTTPException(401, detail="missing or unknown API key (Authorization: Bearer KEY)",
                                headers={"WWW-Authenticate": "Bearer"})
        return "key:" + hashlib.sha256(token.encode()).hexdigest()[:16]
    return request.client.host if request.client else "local"


ClientDep = Annotated[str, Depends(client_id)]


def get_job_or_404(job_id: str, session: SessionDep, client: ClientDep, settings: SettingsDep) -> Job:
    """The job; with API keys, only the key that created it sees it. An id that is not
    32 hex digits is no job, asked of no database (a NUL, say, which PostgreSQL refuses)."""
    if not JOB_ID.fullmatch(job_id):
        raise HTTPException(404, detail=f"no job {job_id[:64]!r}")
    job = crud.get_job(session, job_id)
    if job is None or (settings.api_keys and job.client != client):
        raise HTTPException(404, detail=f"no job {job_id!r}")
    return job


JobDep = Annotated[Job, Depends(get_job_or_404)]
