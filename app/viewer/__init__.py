"""The desktop viewer and its headless twin.

window.py    GLFW window, frame loop, mouse and keys
headless.py  the same scene rendered into an EGL framebuffer (`isoscope render`, tests)
state.py     what is shown: volume, extractor, iso value, flags, messages
renderer.py  the lit mesh, wireframe and bounding box (owns the scene's GL objects)
panel.py     the imgui panel (owns imgui and its native backends)
camera.py    orbit camera, pyrr matrices
slices.py    slice planes, window/level, colour maps, the clip plane (slice_panel.py, slice_options.py)
screenshot.py PNG files

Nothing is imported here: `isoscope --help` must not load GL or GLFW.
"""
