"""texbake's version, from the installed distribution's metadata (one lookup, for the
package, the atlas cache keys and the service)."""

from importlib import metadata as _metadata

try:
    __version__ = _metadata.version("texbake")
except _metadata.PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "0+unknown"
