#include "controls.h"

#include <algorithm>

namespace nfc_viewer {
namespace {

Controls* of(GLFWwindow* window) { return static_cast<Controls*>(glfwGetWindowUserPointer(window)); }

void on_key(GLFWwindow* window, int key, int, int action, int) {
    Controls* c = of(window);
    if (action != GLFW_PRESS || c->overlay_has_keyboard) return;
    switch (key) {
        case GLFW_KEY_ESCAPE: glfwSetWindowShouldClose(window, GLFW_TRUE); break;
        case GLFW_KEY_R: c->camera = c->home; break;
        case GLFW_KEY_W: c->wireframe = !c->wireframe; break;
        case GLFW_KEY_N:
            c->shading = c->shading == Shading::kLit ? Shading::kNormals : Shading::kLit;
            break;
        case GLFW_KEY_C: c->colour = !c->colour; break;
        case GLFW_KEY_O: c->overlay = !c->overlay; break;
        default: break;
    }
}

void on_scroll(GLFWwindow* window, double, double dy) {
    Controls* c = of(window);
    if (c->overlay_has_mouse) return;
    c->camera.distance = std::clamp(c->camera.distance * float(std::pow(0.9, dy)),
                                    0.05f * c->home.distance, 20.0f * c->home.distance);
}

}  // namespace

void Controls::install(GLFWwindow* window) {
    glfwSetWindowUserPointer(window, this);
    glfwSetKeyCallback(window, on_key);
    glfwSetScrollCallback(window, on_scroll);
}

void Controls::update(GLFWwindow* window, bool overlay_mouse) {
    overlay_has_mouse = overlay_mouse;
    double x, y;
    glfwGetCursorPos(window, &x, &y);
    const bool left = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    const bool right = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
    const bool shift = glfwGetKey(window, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS;
    if ((left || right) && dragging && !overlay_mouse) {
        int w = 1, h = 1;
        glfwGetWindowSize(window, &w, &h);
        const float dx = float(x - last_x) / float(std::max(h, 1));
        const float dy = float(y - last_y) / float(std::max(h, 1));
        if (right || shift) {  // pan in the view plane, one window height = the visible height
            const glm::vec3 forward = glm::normalize(camera.target - camera.eye());
            const glm::vec3 side = glm::normalize(glm::cross(forward, glm::vec3(0, 1, 0)));
            const glm::vec3 up = glm::cross(side, forward);
            const float visible = 2.0f * camera.distance * std::tan(0.5f * camera.fov_y);
            camera.target += visible * (-dx * side + dy * up);
        } else {
            camera.yaw -= 3.0f * dx;
            camera.pitch = std::clamp(camera.pitch + 3.0f * dy, -1.5f, 1.5f);
        }
    }
    dragging = left || right;
    last_x = x, last_y = y;
}

}  // namespace nfc_viewer
