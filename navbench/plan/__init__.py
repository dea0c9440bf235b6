"""Planning: exact shortest paths for the task set, A* on the world model, task sampling."""
