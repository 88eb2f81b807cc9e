"""The packing and what every stage shares: the packing and its files, checkpoints, the cell list, seeding,
config limits, the MLS rate ladder, errors, provenance and progress output."""
