"""srg: self-refining games (Stanton et al. 2014) as a production system."""
