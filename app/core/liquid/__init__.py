"""The liquid's maths: scenes, the PCISPH twin, surfaces, silhouettes and what a player sees."""
