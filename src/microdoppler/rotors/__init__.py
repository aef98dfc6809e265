"""Rotor speeds: the paper's sampling variants of logged speeds, and speeds estimated from the radar's HERM lines."""
