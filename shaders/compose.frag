// compose.frag: turns the film's per-component radiance sums into the displayed sRGB pixel.
//
// Each enabled component contributes its resolved radiance times u_scale, the total is multiplied
// by the exposure (2^ev, computed on the CPU), tonemapped (0 = clamp, 1 = Reinhard on Rec.709
// luminance: L' = L/(1+L), colour scaled by L'/L), clamped to 0..1 and encoded with the exact
// piecewise sRGB curve. The render target is an RGBA8 texture the size of the film. With
// u_error_view the pixel is instead the false colour of its error against --reference.
//
// The textures hold the film rows as uploaded, row 0 = top = texel row 0, while gl_FragCoord.y
// counts from the bottom; the fetch flips y so the framebuffer holds the picture upright.
// Absent components are bound to a 1x1 black texture, so fetch coordinates are clamped to
// each texture's own size rather than trusting the film size.
#version 330 core

uniform sampler2D u_component[4];
uniform int u_enabled[4];
uniform float u_scale;
uniform float u_exposure;
uniform int u_tonemap;
uniform int u_height;
uniform sampler2D u_reference; // --reference's total, for u_error_view
uniform int u_error_view;        // 1: each pixel's relative error against it, false colour

out vec4 frag_color;

// A generous ceiling that still cannot overflow after summing 4 components and an
// exposure of 2^64, so no inf (and from inf * 0, no NaN) reaches the tonemap.
const float BIG = 1e15;

// NaN, -inf and negatives become 0, +inf becomes BIG. Tested on the bits so that no compiler
// assumption about NaN-free arithmetic can fold the checks away.
vec3 sanitize(vec3 c) {
    uvec3 bits = floatBitsToUint(c);
    bvec3 special = equal(bits & 0x7f800000u, uvec3(0x7f800000u));
    bvec3 pos_inf = equal(bits, uvec3(0x7f800000u));
    vec3 finite = mix(c, vec3(0.0), special);
    finite = clamp(finite, 0.0, BIG);
    return mix(finite, vec3(BIG), pos_inf);
}

vec3 fetch(sampler2D tex, ivec2 p) {
    ivec2 last = textureSize(tex, 0) - 1;
    return sanitize(texelFetch(tex, min(p, last), 0).rgb);
}

float srgb_encode(float x) {
    return x < 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

// Relative error e = sqrt(mean over channels of (x - r)^2 / (r^2 + 0.01)), the per-pixel term of
// relMSE, on a log scale from 10^-3 (blue) through green (10^-1.5) to 1 and above (red).
vec3 error_colour(vec3 x, vec3 r) {
    vec3 d = x - r;
    float e = sqrt(dot(d * d / (r * r + 0.01), vec3(1.0 / 3.0)));
    float t = clamp((log(max(e, 1e-6)) / log(10.0) + 3.0) / 3.0, 0.0, 1.0);
    return clamp(vec3(2.0 * t - 1.0, 1.0 - abs(2.0 * t - 1.0), 1.0 - 2.0 * t), 0.0, 1.0);
}

void main() {
    ivec2 p = ivec2(int(gl_FragCoord.x), u_height - 1 - int(gl_FragCoord.y));
    if (u_error_view != 0) {
        vec3 total = fetch(u_component[0], p) + fetch(u_component[1], p) + fetch(u_component[2], p) + fetch(u_component[3], p);
        vec3 c = error_colour(total * u_scale, fetch(u_reference, p));
        frag_color = vec4(srgb_encode(c.r), srgb_encode(c.g), srgb_encode(c.b), 1.0);
        return;
    }
    vec3 sum = vec3(0.0);
    // Sampler arrays may only be indexed by constants in GLSL 3.30, hence no loop.
    if (u_enabled[0] != 0) sum += fetch(u_component[0], p);
    if (u_enabled[1] != 0) sum += fetch(u_component[1], p);
    if (u_enabled[2] != 0) sum += fetch(u_component[2], p);
    if (u_enabled[3] != 0) sum += fetch(u_component[3], p);
    vec3 c = sanitize(sum * u_scale * u_exposure);
    if (u_tonemap == 1) {
        float l = dot(c, vec3(0.2126, 0.7152, 0.0722));
        if (l > 0.0) c *= (1.0 / (1.0 + l));  // (L/(1+L)) / L
    }
    c = clamp(c, 0.0, 1.0);
    frag_color = vec4(srgb_encode(c.r), srgb_encode(c.g), srgb_encode(c.b), 1.0);
}
