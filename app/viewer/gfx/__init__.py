"""The viewer's GL side: GPU surfaces and meshes of the volume on show, and the renderers that draw them."""
