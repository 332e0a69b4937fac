"""player_server/protocol."""
