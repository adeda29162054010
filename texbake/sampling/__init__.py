"""texbake.sampling."""
