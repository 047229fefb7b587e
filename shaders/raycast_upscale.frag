#version 410
// A coarse ray-cast picture (a quarter of the pixels, drawn while the view moves) stretched over the
// viewport with linear filtering; premultiplied, blended ONE, ONE_MINUS_SRC_ALPHA over what is drawn.
// Its depth (iso's hits; 1 where a ray hit nothing) goes with it, the nearest of the texels blended, where the depth test is on (iso:
// what is drawn after the rays, the wireframe, stays hidden behind a hit as at rest).
uniform sampler2D u_coarse;
uniform sampler2D u_coarse_depth;
uniform vec4 u_viewport;   // x, y, width, height of the destination, pixels
out vec4 frag_color;

void main() {
    vec2 at = (gl_FragCoord.xy - u_viewport.xy) / u_viewport.zw;
    frag_color = texture(u_coarse, at);
    vec4 depths = textureGather(u_coarse_depth, at);   // the texels the colour is blended from: the nearest
    gl_FragDepth = min(min(depths.x, depths.y), min(depths.z, depths.w));   // hit among them, as its edge shows
}
