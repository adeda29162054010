"""texbake's version: the one place it is written (pyproject.toml's build reads it from
here), so knowing it costs no metadata lookup at import."""

__version__ = "0.1.0"
