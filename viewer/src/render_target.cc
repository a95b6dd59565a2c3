#include "render_target.h"

#include <stb/stb_image_write.h>

#include <algorithm>
#include <stdexcept>

namespace dysa::viewer {

void RenderTarget::Resize(int width, int height) {
  if (width == width_ && height == height_ && framebuffer_.get() != 0) return;
  width_ = width;
  height_ = height;
  if (framebuffer_.get() == 0) {
    framebuffer_ = MakeFramebuffer();
    color_ = MakeTexture();
    depth_ = MakeTexture();
  }
  AllocateTexture2D(color_, GL_RGBA8, width, height, GL_RGBA, GL_UNSIGNED_BYTE, GL_LINEAR);
  AllocateTexture2D(depth_, GL_DEPTH_COMPONENT24, width, height, GL_DEPTH_COMPONENT,
                    GL_UNSIGNED_INT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.get());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color_.get(), 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_.get(), 0);
  CheckFramebuffer("scene render target");
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void RenderTarget::Bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.get());
  glViewport(0, 0, width_, height_);
}

void RenderTarget::BlitTo(GLuint target) const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer_.get());
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, target);
  glBlitFramebuffer(0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, target);
}

std::vector<uint8_t> ReadWindowPixels(int width, int height) {
  std::vector<uint8_t> rows(size_t(width) * size_t(height) * 3);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, rows.data());
  // OpenGL's first row is the bottom one; PNG's is the top one.
  const size_t stride = size_t(width) * 3;
  for (int y = 0; y < height / 2; ++y) {
    std::swap_ranges(rows.begin() + long(y * stride), rows.begin() + long((y + 1) * stride),
                     rows.begin() + long((height - 1 - y) * stride));
  }
  return rows;
}

void WritePng(const std::string& path, const std::vector<uint8_t>& rgb, int width, int height) {
  if (stbi_write_png(path.c_str(), width, height, 3, rgb.data(), width * 3) == 0) {
    throw std::runtime_error("--screenshot: cannot write " + path);
  }
}

}  // namespace dysa::viewer
