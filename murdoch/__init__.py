"""murdoch."""
