"""Players: who played, the player models P(c|v) growth ranks with, and the synthetic bots."""
