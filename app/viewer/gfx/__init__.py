"""The viewer's GL side: GpuScene (the GPU following a ViewerState), the GPU surface of a volume, and the
renderers that draw them."""
