"""Small OpenGL object wrappers (in the spirit of vispy.gloo): program, buffer texture, framebuffer.

Every method needs the caller's OpenGL (>= 4.1 core) context to be current;
objects belong to that context and are freed by ``delete`` (with it current).
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path

import numpy as np
from OpenGL import GL

#: The repository's shader folder.
SHADER_DIR = Path(__file__).resolve().parents[2] / "shaders"


def shader_source(name: str, defines: dict[str, object] | None = None) -> str:
    """The GLSL source ``shaders/<name>`` with ``#define`` lines inserted after its ``#version`` line."""
    text = (SHADER_DIR / name).read_text()
    version, _, rest = text.partition("\n")
    lines = [f"#define {key} {value}" for key, value in (defines or {}).items()]
    return "\n".join([version, *lines, "#line 2", rest])


class ShaderError(RuntimeError):
    """A shader failed to compile or a program to link; the message holds the driver's log."""


def _compile(kind: int, source: str, label: str) -> int:
    shader = GL.glCreateShader(kind)
    GL.glShaderSource(shader, source)
    GL.glCompileShader(shader)
    if not GL.glGetShaderiv(shader, GL.GL_COMPILE_STATUS):
        log = GL.glGetShaderInfoLog(shader)
        GL.glDeleteShader(shader)
        raise ShaderError(f"{label} does not compile:\n{_text(log)}")
    return shader


def _text(log: bytes | str) -> str:
    return log.decode(errors="replace") if isinstance(log, bytes) else str(log)


_SETTERS = {
    GL.GL_FLOAT: lambda loc, v: GL.glUniform1f(loc, float(v)),
    GL.GL_FLOAT_VEC2: lambda loc, v: GL.glUniform2f(loc, *map(float, v)),
    GL.GL_FLOAT_VEC3: lambda loc, v: GL.glUniform3f(loc, *map(float, v)),
    GL.GL_FLOAT_MAT3: lambda loc, v: GL.glUniformMatrix3fv(loc, 1, GL.GL_TRUE, np.asarray(v, np.float32)),
    GL.GL_DOUBLE: lambda loc, v: GL.glUniform1d(loc, float(v)),
    GL.GL_DOUBLE_VEC2: lambda loc, v: GL.glUniform2d(loc, *map(float, v)),
    GL.GL_INT: lambda loc, v: GL.glUniform1i(loc, int(v)),
    GL.GL_INT_VEC2: lambda loc, v: GL.glUniform2i(loc, *map(int, v)),
    GL.GL_BOOL: lambda loc, v: GL.glUniform1i(loc, int(v)),
}
#: Arrays of uniforms, by element type: the element's rank (0 scalar, 1 vector, 2 matrix) and the setter of ``count``.
_ARRAYS = {
    GL.GL_FLOAT: (0, lambda loc, count, v: GL.glUniform1fv(loc, count, v.astype(np.float32))),
    GL.GL_INT: (0, lambda loc, count, v: GL.glUniform1iv(loc, count, v.astype(np.int32))),
    GL.GL_FLOAT_VEC3: (1, lambda loc, count, v: GL.glUniform3fv(loc, count, v.astype(np.float32))),
    GL.GL_FLOAT_MAT3: (2, lambda loc, count, v: GL.glUniformMatrix3fv(loc, count, GL.GL_TRUE, v.astype(np.float32))),
}
_SAMPLERS = {GL.GL_SAMPLER_BUFFER, GL.GL_INT_SAMPLER_BUFFER, GL.GL_UNSIGNED_INT_SAMPLER_BUFFER, GL.GL_SAMPLER_2D}


#: Capabilities our passes and blits never use; Qt (or anyone sharing the context) may leave them on.
_OFF = (GL.GL_BLEND, GL.GL_SCISSOR_TEST, GL.GL_DEPTH_TEST, GL.GL_STENCIL_TEST, GL.GL_CULL_FACE)
_BLEND = (GL.GL_BLEND_SRC_RGB, GL.GL_BLEND_DST_RGB, GL.GL_BLEND_SRC_ALPHA, GL.GL_BLEND_DST_ALPHA,
          GL.GL_BLEND_EQUATION_RGB, GL.GL_BLEND_EQUATION_ALPHA)


@contextmanager
def plain_state() -> Iterator[None]:
    """Run the body with blending, scissor, depth, stencil and culling off and every colour written.

    Whatever the context had before is put back afterwards, so that neither
    the caller's state nor an earlier draw changes what the body writes.
    Inside, a pass that needs more (``additive``, a scissor) sets it and
    turns it off again.
    """
    enabled = {cap: bool(GL.glIsEnabled(cap)) for cap in _OFF}
    blend = [int(GL.glGetIntegerv(name)) for name in _BLEND]
    mask = [bool(v) for v in GL.glGetBooleanv(GL.GL_COLOR_WRITEMASK)]
    for cap in _OFF:
        GL.glDisable(cap)
    GL.glColorMask(True, True, True, True)
    try:
        yield
    finally:
        for cap, on in enabled.items():
            (GL.glEnable if on else GL.glDisable)(cap)
        GL.glBlendFuncSeparate(*blend[:4])
        GL.glBlendEquationSeparate(*blend[4:])
        GL.glColorMask(*mask)


def in_plain_state(method):
    """Run a GL-drawing method in ``plain_state``: it sets what its passes need and restores the rest."""
    @functools.wraps(method)
    def wrapped(self, *args, **kwargs):
        with plain_state():
            return method(self, *args, **kwargs)
    return wrapped


@contextmanager
def _blending(colour: tuple[int, int], alpha: tuple[int, int]) -> Iterator[None]:
    """Blend the body's fragments into the target, ``colour`` and ``alpha`` the (source, destination) factors
    of the colour and alpha channels; then blend no more."""
    GL.glEnable(GL.GL_BLEND)
    GL.glBlendEquation(GL.GL_FUNC_ADD)
    GL.glBlendFuncSeparate(*colour, *alpha)
    try:
        yield
    finally:
        GL.glBlendFunc(GL.GL_ONE, GL.GL_ZERO)
        GL.glDisable(GL.GL_BLEND)


def over() -> AbstractContextManager[None]:
    """Blend the body's fragments over the target by their alpha (``SRC_ALPHA, ONE_MINUS_SRC_ALPHA``); the
    target's alpha becomes the coverage, ``a + (1 - a) below`` (over an opaque target it stays 1: the window
    system composes the canvas by it)."""
    return _blending((GL.GL_SRC_ALPHA, GL.GL_ONE_MINUS_SRC_ALPHA), (GL.GL_ONE, GL.GL_ONE_MINUS_SRC_ALPHA))


def through_below() -> AbstractContextManager[None]:
    """Blend the body's fragments ``(C, T)`` as ``C + T below`` (``ONE, SRC_ALPHA``: ``shaders/layers.frag``'s
    later passes), the target's coverage kept."""
    return _blending((GL.GL_ONE, GL.GL_SRC_ALPHA), (GL.GL_ZERO, GL.GL_ONE))


def additive() -> AbstractContextManager[None]:
    """Add the body's fragments to the target (blending ``ONE, ONE``), then blend no more."""
    return _blending((GL.GL_ONE, GL.GL_ONE), (GL.GL_ONE, GL.GL_ONE))


class Program:
    """A linked vertex + fragment program with uniforms set by name.

    Parameters
    ----------
    vertex, fragment : str
        GLSL sources.
    label : str
        Names the program in error messages.

    Raises
    ------
    ShaderError
        When a shader does not compile or the program does not link.
    """

    def __init__(self, vertex: str, fragment: str, label: str = "program") -> None:
        shaders = [_compile(GL.GL_VERTEX_SHADER, vertex, f"{label} (vertex)"),
                   _compile(GL.GL_FRAGMENT_SHADER, fragment, f"{label} (fragment)")]
        self.handle = GL.glCreateProgram()
        for shader in shaders:
            GL.glAttachShader(self.handle, shader)
        GL.glLinkProgram(self.handle)
        for shader in shaders:
            GL.glDetachShader(self.handle, shader)
            GL.glDeleteShader(shader)
        if not GL.glGetProgramiv(self.handle, GL.GL_LINK_STATUS):
            log = GL.glGetProgramInfoLog(self.handle)
            GL.glDeleteProgram(self.handle)
            raise ShaderError(f"{label} does not link:\n{_text(log)}")
        self._uniforms: dict[str, tuple[int, int]] = {}
        for index in range(GL.glGetProgramiv(self.handle, GL.GL_ACTIVE_UNIFORMS)):
            name, _, kind = GL.glGetActiveUniform(self.handle, index)
            name = _text(name).split("[")[0]
            self._uniforms[name] = (GL.glGetUniformLocation(self.handle, name), int(kind))

    def use(self) -> None:
        GL.glUseProgram(self.handle)

    def __contains__(self, name: str) -> bool:
        return name in self._uniforms

    def set(self, **values) -> None:
        """Set uniforms by name (the program must be in use); names the linker removed are ignored.

        Samplers take their texture unit; an array of floats, ints, vec3 or mat3 takes a sequence of them.
        """
        for name, value in values.items():
            found = self._uniforms.get(name)
            if found is None:
                continue
            location, kind = found
            if kind in _ARRAYS and np.ndim(value) == _ARRAYS[kind][0] + 1:  # an array
                value = np.ascontiguousarray(value)
                _ARRAYS[kind][1](location, len(value), value)
            elif kind in _SAMPLERS:
                GL.glUniform1i(location, int(value))
            else:
                _SETTERS[kind](location, value)

    def delete(self) -> None:
        if self.handle:
            GL.glDeleteProgram(self.handle)
            self.handle = 0


class BufferTexture:
    """A buffer object seen by shaders as a ``samplerBuffer`` (texel fetches).

    Parameters
    ----------
    internal_format : int
        ``GL_RGBA32F`` (float32 texels of 4) or ``GL_R32I`` (int32), say.
    """

    _DTYPES = {GL.GL_RGBA32F: (np.float32, 4), GL.GL_R32F: (np.float32, 1), GL.GL_R32I: (np.int32, 1)}

    def __init__(self, internal_format: int = GL.GL_RGBA32F) -> None:
        self.internal_format = internal_format
        self.dtype, self.components = self._DTYPES[internal_format]
        self.buffer = int(GL.glGenBuffers(1))
        self.texture = int(GL.glGenTextures(1))
        self.size = 0  # texels

    def _array(self, data: np.ndarray) -> np.ndarray:
        data = np.ascontiguousarray(data, self.dtype)
        if data.size % self.components:
            raise ValueError(f"need whole texels of {self.components} values")
        return data

    def set_data(self, data: np.ndarray) -> None:
        """Replace the contents (and size) with ``data``; an empty array keeps one zero texel."""
        data = self._array(data)
        if data.size == 0:
            data = np.zeros(self.components, self.dtype)
        GL.glBindBuffer(GL.GL_TEXTURE_BUFFER, self.buffer)
        GL.glBufferData(GL.GL_TEXTURE_BUFFER, data.nbytes, data, GL.GL_DYNAMIC_DRAW)
        GL.glBindBuffer(GL.GL_TEXTURE_BUFFER, 0)
        GL.glBindTexture(GL.GL_TEXTURE_BUFFER, self.texture)
        GL.glTexBuffer(GL.GL_TEXTURE_BUFFER, self.internal_format, self.buffer)
        GL.glBindTexture(GL.GL_TEXTURE_BUFFER, 0)
        self.size = data.size // self.components

    def set_subdata(self, texel: int, data: np.ndarray) -> None:
        """Overwrite texels from ``texel`` on with ``data`` (within the current size)."""
        data = self._array(data)
        count = data.size // self.components
        if texel < 0 or texel + count > self.size:
            raise ValueError(f"texels {texel}:{texel + count} outside the buffer's {self.size}")
        GL.glBindBuffer(GL.GL_TEXTURE_BUFFER, self.buffer)
        GL.glBufferSubData(GL.GL_TEXTURE_BUFFER, texel * self.components * data.itemsize, data.nbytes, data)
        GL.glBindBuffer(GL.GL_TEXTURE_BUFFER, 0)

    def bind(self, unit: int) -> None:
        GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
        GL.glBindTexture(GL.GL_TEXTURE_BUFFER, self.texture)

    def delete(self) -> None:
        if self.texture:
            GL.glDeleteTextures([self.texture])
            GL.glDeleteBuffers(1, [self.buffer])
            self.texture = self.buffer = 0


class Framebuffer:
    """A framebuffer object with one 2D colour texture.

    Parameters
    ----------
    internal_format : int
        ``GL_RGBA8`` (what a window shows) or ``GL_RGBA32F`` (unclamped floats).
    """

    def __init__(self, internal_format: int = GL.GL_RGBA8) -> None:
        self.internal_format = internal_format
        self.handle = int(GL.glGenFramebuffers(1))
        self.texture = int(GL.glGenTextures(1))
        self.width = self.height = 0

    def resize(self, width: int, height: int) -> None:
        """Reallocate the colour texture (contents undefined) unless the size is already this."""
        if (width, height) == (self.width, self.height):
            return
        kind = GL.GL_FLOAT if self.internal_format == GL.GL_RGBA32F else GL.GL_UNSIGNED_BYTE
        GL.glBindTexture(GL.GL_TEXTURE_2D, self.texture)
        GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, self.internal_format, width, height, 0, GL.GL_RGBA, kind, None)
        for parameter in (GL.GL_TEXTURE_MIN_FILTER, GL.GL_TEXTURE_MAG_FILTER):
            GL.glTexParameteri(GL.GL_TEXTURE_2D, parameter, GL.GL_NEAREST)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.handle)
        GL.glFramebufferTexture2D(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0, GL.GL_TEXTURE_2D, self.texture, 0)
        status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
        if status != GL.GL_FRAMEBUFFER_COMPLETE:
            raise RuntimeError(f"framebuffer incomplete (status 0x{int(status):x})")
        self.width, self.height = width, height

    def bind(self) -> None:
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.handle)
        GL.glViewport(0, 0, self.width, self.height)

    def read(self) -> np.ndarray:
        """The colour texture as ``(height, width, 4)``, top row first (window rows): uint8 or float32."""
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.handle)
        GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
        if self.internal_format == GL.GL_RGBA32F:
            data = GL.glReadPixels(0, 0, self.width, self.height, GL.GL_RGBA, GL.GL_FLOAT)
            image = np.frombuffer(data, np.float32)
        else:
            data = GL.glReadPixels(0, 0, self.width, self.height, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE)
            image = np.frombuffer(data, np.uint8)
        return image.reshape(self.height, self.width, 4)[::-1].copy()

    def blit_to(self, target: int, dx: int = 0, dy: int = 0) -> None:
        """Copy the colour texture pixel for pixel into framebuffer ``target``, moved by ``(dx, dy)`` GL pixels."""
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.handle)
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, target)
        GL.glBlitFramebuffer(0, 0, self.width, self.height, dx, dy, dx + self.width, dy + self.height,
                             GL.GL_COLOR_BUFFER_BIT, GL.GL_NEAREST)

    def delete(self) -> None:
        if self.handle:
            GL.glDeleteFramebuffers(1, [self.handle])
            GL.glDeleteTextures([self.texture])
            self.handle = self.texture = 0


class VertexArray:
    """An empty vertex array object (core profiles draw only with one bound; our quads come from gl_VertexID)."""

    def __init__(self) -> None:
        self.handle = int(GL.glGenVertexArrays(1))

    def bind(self) -> None:
        GL.glBindVertexArray(self.handle)

    def delete(self) -> None:
        if self.handle:
            GL.glDeleteVertexArrays(1, [self.handle])
            self.handle = 0
