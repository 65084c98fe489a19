"""ringsim: collisional N-body simulations of a planetary-ring patch."""

__version__ = "0.1.0"
