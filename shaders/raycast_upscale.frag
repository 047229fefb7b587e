#version 410
// A coarse ray-cast picture (a quarter of the pixels, drawn while the view moves) stretched over the
// viewport with linear filtering; premultiplied, blended ONE, ONE_MINUS_SRC_ALPHA over what is drawn.
uniform sampler2D u_coarse;
uniform vec4 u_viewport;   // x, y, width, height of the destination, pixels
out vec4 frag_color;

void main() {
    frag_color = texture(u_coarse, (gl_FragCoord.xy - u_viewport.xy) / u_viewport.zw);
}
