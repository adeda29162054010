"""texbake.maps."""
