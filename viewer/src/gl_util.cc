#include "gl_util.h"

#include <cstdio>
#include <string>
#include <vector>

namespace dysa::viewer {

void DeleteProgram(GLuint id) { glDeleteProgram(id); }
void DeleteBuffer(GLuint id) { glDeleteBuffers(1, &id); }
void DeleteVertexArray(GLuint id) { glDeleteVertexArrays(1, &id); }
void DeleteTexture(GLuint id) { glDeleteTextures(1, &id); }
void DeleteFramebuffer(GLuint id) { glDeleteFramebuffers(1, &id); }

namespace {
// One name from a glGen* function.
GLuint Generate(void (*gen)(GLsizei, GLuint*)) {
  GLuint id = 0;
  gen(1, &id);
  return id;
}
}  // namespace

Buffer MakeBuffer() { return Buffer(Generate(glGenBuffers)); }
VertexArray MakeVertexArray() { return VertexArray(Generate(glGenVertexArrays)); }
Texture MakeTexture() { return Texture(Generate(glGenTextures)); }
Framebuffer MakeFramebuffer() { return Framebuffer(Generate(glGenFramebuffers)); }

namespace {

GLuint CompileStage(const std::string& name, GLenum stage, const char* source) {
  const GLuint shader = glCreateShader(stage);
  const char* sources[] = {"#version 330 core\n", source};
  glShaderSource(shader, 2, sources, nullptr);
  glCompileShader(shader);
  GLint ok = GL_FALSE;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok == GL_TRUE) return shader;
  GLint length = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
  std::vector<char> log(size_t(length > 0 ? length : 1), '\0');
  glGetShaderInfoLog(shader, length, nullptr, log.data());
  glDeleteShader(shader);
  throw GlError("shader " + name + (stage == GL_VERTEX_SHADER ? " (vertex)" : " (fragment)") +
                " does not compile: " + log.data());
}

}  // namespace

Program LinkProgram(const std::string& name, const char* vertex_source,
                    const char* fragment_source) {
  const GLuint vertex = CompileStage(name, GL_VERTEX_SHADER, vertex_source);
  GLuint fragment = 0;
  try {
    fragment = CompileStage(name, GL_FRAGMENT_SHADER, fragment_source);
  } catch (...) {
    glDeleteShader(vertex);
    throw;
  }
  Program program(glCreateProgram());
  glAttachShader(program.get(), vertex);
  glAttachShader(program.get(), fragment);
  glLinkProgram(program.get());
  glDeleteShader(vertex);  // flagged; freed with the program
  glDeleteShader(fragment);
  GLint ok = GL_FALSE;
  glGetProgramiv(program.get(), GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint length = 0;
    glGetProgramiv(program.get(), GL_INFO_LOG_LENGTH, &length);
    std::vector<char> log(size_t(length > 0 ? length : 1), '\0');
    glGetProgramInfoLog(program.get(), length, nullptr, log.data());
    throw GlError("shader " + name + " does not link: " + log.data());
  }
  return program;
}

GLint Uniform(const Program& program, const char* name) {
  return glGetUniformLocation(program.get(), name);
}

void AllocateTexture2D(const Texture& texture, GLint internal_format, GLsizei width, GLsizei height,
                       GLenum format, GLenum type, GLint filter) {
  glBindTexture(GL_TEXTURE_2D, texture.get());
  glTexImage2D(GL_TEXTURE_2D, 0, internal_format, width, height, 0, format, type, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D, 0);
}

void CheckFramebuffer(const char* what) {
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    throw GlError(std::string(what) + ": framebuffer incomplete (status 0x" + [status] {
      char hex[16];
      std::snprintf(hex, sizeof(hex), "%x", status);
      return std::string(hex);
    }() + ")");
  }
}

}  // namespace dysa::viewer
