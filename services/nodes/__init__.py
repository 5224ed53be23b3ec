"""The live processes: camera, detector and recorder nodes, and replay of a recording on the bus."""
