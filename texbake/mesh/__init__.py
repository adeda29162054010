"""texbake.mesh."""
