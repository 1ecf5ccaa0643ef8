"""selfsense: position self-sensing of piezoelectric actuators (Islam 2013, Ronkanen 2002)."""

__version__ = "0.1.0"
