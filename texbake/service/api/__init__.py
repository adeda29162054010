"""texbake.service.api."""
