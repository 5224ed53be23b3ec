"""Who may use the web service: accounts, roles and password hashes (shared by the API, the CLI and the demo stack)."""
