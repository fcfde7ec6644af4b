// Offscreen pictures of the machine for report.html (src/report/render.rs):
// triangles and lines in the part frame, one colour per vertex, lit by a
// light at the camera (flat: the face normal from the screen derivatives).
// A vertex whose colour has alpha 0 is drawn unlit, at full colour: the
// highlights and the toolpath.

struct View {
    // Part frame → clip space.
    view_proj: mat4x4<f32>,
    // The camera's position (part frame), w unused.
    eye: vec4<f32>,
};

@group(0) @binding(0) var<uniform> view: View;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) color: vec4<f32>,
};

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) color: vec4<f32>) -> VertexOut {
    var out: VertexOut;
    out.clip = view.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    out.color = color;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    if (in.color.a < 0.5) {
        return vec4<f32>(in.color.rgb, 1.0);
    }
    let n = cross(dpdx(in.world), dpdy(in.world));
    let len = length(n);
    var lit = 1.0;
    if (len > 0.0) {
        let to_eye = normalize(view.eye.xyz - in.world);
        lit = 0.35 + 0.65 * abs(dot(n / len, to_eye));
    }
    return vec4<f32>(in.color.rgb * lit, 1.0);
}
