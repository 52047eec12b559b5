"""Integration tests: real server and worker processes."""
