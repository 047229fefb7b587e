"""The viewer's front: the glfw window, the imgui panel, and the headless viewer that draws the same."""
