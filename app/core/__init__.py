"""The pure core: stdlib, numpy and scipy only. Nothing here opens a file, a session or a socket."""
