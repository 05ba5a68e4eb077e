"""api package of romams."""
