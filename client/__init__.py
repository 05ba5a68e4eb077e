"""client package of romams."""
