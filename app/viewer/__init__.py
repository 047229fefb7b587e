"""The desktop viewer and its headless twin, in three layers.

model/  what is shown and how it may change, without GL (no moderngl import): the camera, style,
        slice settings, value histogram, recent files, big volumes' step and export, colour maps
gfx/    GL: the GPU surface of the volume on show, the scene renderer, slices, translucency,
        colour by a scalar, screenshots
ui/     the glfw window and its frame loop, the imgui panel and its sections, the headless
        viewer (`isoscope render`, tests) that draws the same panel into an EGL framebuffer

model/ imports nothing of gfx/ or ui/; gfx/ imports model/; ui/ imports both.
Nothing is imported here: `isoscope --help` must not load GL or GLFW.
"""
