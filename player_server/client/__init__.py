"""player_server/client."""
