"""Service settings, from the environment (prefix ``BAKE_``) or a ``.env`` file.

Read through :func:`get_settings` (cached), never at import time, so tests can override.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="BAKE_", env_file=".env", extra="ignore")

    data_dir: Path = Field(Path.home() / ".texbake", description="uploads, outputs, SQLite queue and jobs")
    redis_url: str | None = Field(None, description="Redis for the queue (default: SQLite in data_dir)")
    database_url: str | None = Field(None, description="SQLAlchemy URL of the jobs table (default: SQLite)")
    base_url: str | None = Field(None, description="the API's public URL, for job URLs (default: the request's, Host header included)")
    storage_url: str | None = Field(None, description="s3://bucket/prefix: uploads and outputs in an object store (default: in data_dir)")
    s3_endpoint: str | None = Field(None, description="the S3-compatible server's URL when not AWS's (http:// allowed), e.g. MinIO's")
    log_format: Literal["text", "json"] = Field("text", description="json: one JSON object per log line")
    api_keys: list[str] = Field(default_factory=list, description="bearer tokens; empty: no authentication")
    max_upload_bytes: int = 256 * 1024 * 1024
    max_faces: int = 2_000_000
    max_size: int = 8192
    max_samples: int = 64
    max_frames: int = 64  # frames of an animated bake
    jobs_per_client: int = 50  # unfinished jobs a client may have
    database_wait_seconds: float = Field(3.0, gt=0, description="longest wait for a database connection (or SQLite's write lock); then 503")
    workers: int = 2
    job_seconds: float = 900.0  # deadline of one bake
    job_memory_mb: int = 6144  # address-space limit of one bake
    stop_seconds: float = 20.0  # on SIGTERM, running bakes get this long to finish, then go back to the queue
    heartbeat_seconds: float = 2.0
    stale_seconds: float = 30.0  # a running job without heartbeat for this long is re-queued
    requeue_seconds: float = 60.0  # a queued job missing from the queue for this long is enqueued again
    max_attempts: int = 3
    min_free_mb: int = 1024  # /readyz says not ready with less free space in data_dir
    keep_hours: float = 168.0  # a done job (row, folder, outputs) is deleted this long after it finished
    keep_failed_hours: float = 24.0  # a failed or cancelled one this long after

    @field_validator("storage_url")
    @classmethod
    def _s3_only(cls, url: str | None) -> str | None:
        if url is not None and not (url.startswith("s3://") and len(url) > len("s3://")):
            raise ValueError(f"{url!r} is not an s3://bucket/prefix URL")
        return url

    @property
    def database(self) -> str:
        return self.database_url or f"sqlite:///{self.data_dir / 'jobs.db'}"


@lru_cache
def get_settings() -> Settings:
    settings = Settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    return settings
