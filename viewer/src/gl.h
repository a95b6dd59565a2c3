// The OpenGL 3.3 core API. Linux's libOpenGL (glvnd) exports every core entry point, so the
// prototypes are used directly and no loader library is needed.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
