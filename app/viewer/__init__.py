"""The desktop viewer and its headless twin, in three layers.

model/  what is shown and how it may change, without GL (no moderngl import): ViewerState and its
        parts (levels, mesh options, slices, label map, colour by, background jobs with a request id
        in and a response out), the camera, style, histogram, recent files, big volumes' step and
        export.  Refusals are exceptions; the panel shows their one line.
gfx/    GL: GpuScene, which brings the GPU in line with a ViewerState once a frame (uploads, extracts,
        keeps each level's mesh), the GPU surface of a volume (or its CPU twin on OpenGL 4.1, whose
        meshes are uploaded as vertex buffers), the renderer, slices, translucency, colour by's textures,
        screenshots.  Drawing needs OpenGL 4.1 core (the shaders are #version 410); extracting on the
        GPU needs 4.3
ui/     the glfw window and its frame loop, the imgui panel and its sections, and the headless viewer
        (`isoscope render`, tests), which lays out the same panel and so sits beside the window

model/ imports nothing of gfx/ or ui/; gfx/ imports model/; ui/ imports both.  A frame: the panel
changes the state (nothing extracted during its layout), then GpuScene.update, then the renderer.
Nothing is imported here: `isoscope --help` must not load GL or GLFW.
"""
