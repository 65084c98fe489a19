"""Pure numpy physics: restitution laws, size distributions, kinetic theory, contact models."""
