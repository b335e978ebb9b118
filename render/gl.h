// The one place render/ includes OpenGL: core-profile prototypes straight from the system GL
// library (Mesa and GLVND export every 3.3 entry point), so no loader library is needed.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
