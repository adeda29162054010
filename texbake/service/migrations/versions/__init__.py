"""One module a migration, oldest first (``r0001_...``)."""
