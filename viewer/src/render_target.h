// An offscreen framebuffer with a colour texture (RGBA8) and a depth texture (24 bit), sized to
// the window. The scene is drawn into it; then it is either copied to the window (particle mode)
// or read by the fluid renderer as the background behind the surface.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gl_util.h"

namespace dysa::viewer {

class RenderTarget {
 public:
  // (Re)allocates the textures when the size changes.
  void Resize(int width, int height);
  void Bind() const;  // as the draw framebuffer, with a full viewport
  // Copies the colour to framebuffer `target` (0: the window) at the same size.
  void BlitTo(GLuint target) const;

  GLuint framebuffer() const { return framebuffer_.get(); }
  GLuint color() const { return color_.get(); }
  GLuint depth() const { return depth_.get(); }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  Framebuffer framebuffer_;
  Texture color_;
  Texture depth_;
  int width_ = 0;
  int height_ = 0;
};

// The window's back buffer as tightly packed RGB rows, top row first.
std::vector<uint8_t> ReadWindowPixels(int width, int height);

// Writes RGB rows (top first) as a PNG; throws std::runtime_error naming the file on failure.
void WritePng(const std::string& path, const std::vector<uint8_t>& rgb, int width, int height);

}  // namespace dysa::viewer
