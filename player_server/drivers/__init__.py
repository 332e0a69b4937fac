"""player_server/drivers."""
