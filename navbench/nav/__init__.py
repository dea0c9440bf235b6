"""Navigation: the waypoint controller, the episode loop and offline scoring."""
