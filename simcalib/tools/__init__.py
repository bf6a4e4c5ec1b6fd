"""Developer tools (screenshots of recordings)."""
