"""player_server/viz."""
