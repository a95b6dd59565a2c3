// Small RAII owners of OpenGL objects and shader compilation with readable errors. Every
// function here needs a current OpenGL 3.3 core context.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>

#include "gl.h"

namespace dysa::viewer {

// A shader that does not compile or link; what() holds the driver's log and the stage.
class GlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Owns one GL object name; Deleter is the glDelete* call for its kind.
template <void (*Deleter)(GLuint)>
class GlHandle {
 public:
  GlHandle() = default;
  explicit GlHandle(GLuint id) : id_(id) {}
  ~GlHandle() { Reset(); }
  GlHandle(GlHandle&& other) noexcept : id_(std::exchange(other.id_, 0)) {}
  GlHandle& operator=(GlHandle&& other) noexcept {
    if (this != &other) {
      Reset();
      id_ = std::exchange(other.id_, 0);
    }
    return *this;
  }
  GlHandle(const GlHandle&) = delete;
  GlHandle& operator=(const GlHandle&) = delete;

  GLuint get() const { return id_; }
  void Reset() {
    if (id_ != 0) Deleter(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

void DeleteProgram(GLuint id);
void DeleteBuffer(GLuint id);
void DeleteVertexArray(GLuint id);
void DeleteTexture(GLuint id);
void DeleteFramebuffer(GLuint id);

using Program = GlHandle<DeleteProgram>;
using Buffer = GlHandle<DeleteBuffer>;
using VertexArray = GlHandle<DeleteVertexArray>;
using Texture = GlHandle<DeleteTexture>;
using Framebuffer = GlHandle<DeleteFramebuffer>;

Buffer MakeBuffer();
VertexArray MakeVertexArray();
Texture MakeTexture();
Framebuffer MakeFramebuffer();

// Compiles and links a vertex + fragment shader pair ("#version 330 core" is prepended).
// `name` appears in the error message. Throws GlError with the driver's log.
Program LinkProgram(const std::string& name, const char* vertex_source,
                    const char* fragment_source);

// The location of a uniform; -1 (ignored by glUniform*) when the driver optimised it away.
GLint Uniform(const Program& program, const char* name);

// A 2D texture of the given format for render targets (no mipmaps, clamped, `filter`).
void AllocateTexture2D(const Texture& texture, GLint internal_format, GLsizei width, GLsizei height,
                       GLenum format, GLenum type, GLint filter);

// Throws GlError naming `what` when the bound framebuffer is incomplete.
void CheckFramebuffer(const char* what);

}  // namespace dysa::viewer
