"""Growth: which blend to replace by simulation next, and the loop that grows a graph."""
