"""Measurements on a packing: contacts and rattlers, structure (g(r), Voronoi, bond order), the Farr–Groot
estimate of phi_RCP, and the force and gap distributions of a certified packing with their power-law fits."""
