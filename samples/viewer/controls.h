// Mouse and keys: the orbit camera (left drag rotates, right or shift + left drag pans, the wheel
// zooms) and the view toggles (R reset, W wireframe, N shading, C colour, O overlay, Esc quit).
#pragma once

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "mesh_pipeline.h"
#include "scene.h"

namespace nfc_viewer {

struct Controls {
    OrbitCamera camera, home;  // home: what R resets to
    bool wireframe = false;
    Shading shading = Shading::kLit;
    bool colour = true;  // lit: the vertex colours of the meshes that have them, else the tint
    bool overlay = true;

    // Installs the key and scroll callbacks (before ImGui's, which chain to them); `this` must
    // outlive the window's use of them.
    void install(GLFWwindow* window);
    // Applies this frame's mouse drag unless the overlay has the mouse.
    void update(GLFWwindow* window, bool overlay_has_mouse);

    double last_x = 0, last_y = 0;
    bool dragging = false;
    bool overlay_has_mouse = false;
    bool overlay_has_keyboard = false;
};

}  // namespace nfc_viewer
