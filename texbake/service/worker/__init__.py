"""texbake.service.worker."""
