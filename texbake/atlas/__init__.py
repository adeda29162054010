"""texbake.atlas."""
