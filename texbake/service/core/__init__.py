"""texbake.service.core."""
