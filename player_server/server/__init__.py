"""player_server/server."""
