"""worker package of romams."""
