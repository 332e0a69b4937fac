"""player_server/sim."""
