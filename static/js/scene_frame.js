// The 3D views (live mirror, session replay) are viser pages on their own ports, shown in iframes. Shared by the
// mission-control and sessions pages.
"use strict";

// Software WebGL in the same page (or a same-site iframe) blocks this page's main thread for tens of ms per
// frame and would delay the e-stop. 127.0.0.1 and localhost are different sites, so the iframe gets its own
// renderer process when we swap one for the other.
function sceneHost() {
  const host = location.hostname;
  if (host === "127.0.0.1") return { host: "localhost", crossSite: true };
  if (host === "localhost") return { host: "127.0.0.1", crossSite: true };
  return { host, crossSite: false };
}

// Where WebGL runs in software (no GPU: SwiftShader, llvmpipe), each 3D frame costs hundreds of ms of CPU;
// rendering at half resolution cuts that fourfold and keeps the machine responsive.
function softwareWebGL() {
  try {
    const gl = document.createElement("canvas").getContext("webgl");
    if (!gl) return true;
    const info = gl.getExtension("WEBGL_debug_renderer_info");
    const renderer = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
    const lose = gl.getExtension("WEBGL_lose_context");
    if (lose) lose.loseContext(); // this page keeps no GPU context: nothing on it may wait for the GPU process
    return /swiftshader|llvmpipe|software|softpipe/i.test(String(renderer));
  } catch (e) {
    return true;
  }
}

