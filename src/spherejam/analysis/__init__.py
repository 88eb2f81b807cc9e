"""Measurements on a packing: contacts and rattlers, structure (g(r), Voronoi, bond order), and the Farr–Groot
estimate of phi_RCP."""
