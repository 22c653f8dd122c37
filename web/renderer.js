// WebGL 2 drawing of textured meshes: each vertex has its previous and its new screen position
// (the geomorph pair) and an atlas texture coordinate; the vertex shader interpolates between the
// two positions, so an animation frame costs one uniform, not a buffer upload.

const VERTEX_SHADER = `#version 300 es
in vec2 a_from;
in vec2 a_to;
in vec2 a_texcoord;
uniform float u_t;       // 0: previous view, 1: new view
uniform vec2 u_size;     // pane size, CSS pixels (the mesh's screen units)
out vec2 v_texcoord;
void main() {
  vec2 p = mix(a_from, a_to, u_t);
  gl_Position = vec4(p.x / u_size.x * 2.0 - 1.0, 1.0 - p.y / u_size.y * 2.0, 0.0, 1.0);
  v_texcoord = a_texcoord;
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
in vec2 v_texcoord;
uniform sampler2D u_atlas;
out vec4 color;
void main() {
  color = texture(u_atlas, v_texcoord);
}`;

export class Renderer {
  constructor(canvas) {
    this.canvas = canvas;
    // preserveDrawingBuffer: the picture stays readable (tests, screenshots) after compositing.
    // No antialiasing: the server samples at pixel centres, and so does plain rasterisation.
    const gl = canvas.getContext('webgl2', { preserveDrawingBuffer: true, antialias: false, alpha: false });
    if (!gl) throw new Error('this browser has no WebGL 2');
    this.gl = gl;
    this.program = linkProgram(gl, VERTEX_SHADER, FRAGMENT_SHADER);
    this.attributes = ['a_from', 'a_to', 'a_texcoord'].map((name) => gl.getAttribLocation(this.program, name));
    this.uniforms = {
      t: gl.getUniformLocation(this.program, 'u_t'),
      size: gl.getUniformLocation(this.program, 'u_size'),
    };
    this.maxTextureSize = gl.getParameter(gl.MAX_TEXTURE_SIZE);
    this.pixelRatio = 1;
  }

  // An empty linearly filtered texture of width × height texels, for uploadTile().
  createTexture(width, height) {
    const gl = this.gl;
    const texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA8, width, height);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    return texture;
  }

  // Copies a decoded (premultiplied) tile into the texture with its top-left texel at (x, y).
  uploadTile(texture, bitmap, x, y) {
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, x, y, gl.RGBA, gl.UNSIGNED_BYTE, bitmap);
  }

  deleteTexture(texture) {
    this.gl.deleteTexture(texture);
  }

  // GPU buffers of a parsed mesh (geometry.js) with its texture coordinates.
  createMesh(mesh, texcoords) {
    const gl = this.gl;
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const buffers = [mesh.from, mesh.screen, texcoords].map((data, k) => {
      const buffer = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.bufferData(gl.ARRAY_BUFFER, data instanceof Float32Array ? data : new Float32Array(data), gl.STATIC_DRAW);
      gl.enableVertexAttribArray(this.attributes[k]);
      gl.vertexAttribPointer(this.attributes[k], 2, gl.FLOAT, false, 0, 0);
      return buffer;
    });
    const indices = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, indices);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, mesh.triangles, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return { vao, buffers: [...buffers, indices], count: mesh.triangles.length };
  }

  deleteMesh(drawable) {
    this.gl.deleteVertexArray(drawable.vao);
    for (const buffer of drawable.buffers) this.gl.deleteBuffer(buffer);
  }

  // Sizes the drawing buffer to the canvas's CSS size in device pixels and clears it to black,
  // the colour the server gives screen pixels no triangle covers.
  beginFrame(cssWidth, cssHeight, pixelRatio) {
    const gl = this.gl;
    this.pixelRatio = pixelRatio;
    const width = Math.max(1, Math.round(cssWidth * pixelRatio));
    const height = Math.max(1, Math.round(cssHeight * pixelRatio));
    if (this.canvas.width !== width || this.canvas.height !== height) {
      this.canvas.width = width;
      this.canvas.height = height;
    }
    gl.disable(gl.SCISSOR_TEST);
    gl.clearColor(0, 0, 0, 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
  }

  // Draws a mesh into `rect` (CSS pixels, origin top-left) at animation time t.
  draw(drawable, texture, rect, t) {
    const gl = this.gl;
    const r = this.pixelRatio;
    const x = Math.round(rect.x * r);
    const width = Math.round((rect.x + rect.width) * r) - x;
    const height = Math.round(rect.height * r);
    const y = this.canvas.height - Math.round(rect.y * r) - height;  // GL counts rows from the bottom
    gl.viewport(x, y, width, height);
    gl.enable(gl.SCISSOR_TEST);
    gl.scissor(x, y, width, height);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    gl.useProgram(this.program);
    gl.uniform1f(this.uniforms.t, t);
    gl.uniform2f(this.uniforms.size, rect.width, rect.height);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.bindVertexArray(drawable.vao);
    gl.drawElements(gl.TRIANGLES, drawable.count, gl.UNSIGNED_INT, 0);
    gl.bindVertexArray(null);
  }
}

function linkProgram(gl, vertexSource, fragmentSource) {
  const program = gl.createProgram();
  for (const [type, source] of [[gl.VERTEX_SHADER, vertexSource], [gl.FRAGMENT_SHADER, fragmentSource]]) {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, source);
    gl.compileShader(shader);
    if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(shader));
    gl.attachShader(program, shader);
  }
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
  return program;
}
