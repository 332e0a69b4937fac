"""Player 3.x compatible device server over a PyBullet world, and its Python client."""
