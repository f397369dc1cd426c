"""The state graph, its published copies, STATERANK, and the one protocol a game implements."""
