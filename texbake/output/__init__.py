"""texbake.output."""
