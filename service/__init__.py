"""meshservice: the HTTP service running meshcore methods as jobs."""
