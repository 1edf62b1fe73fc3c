// The 3D views (live mirror, session replay) are viser pages behind the server's gates, on their own ports, shown
// in iframes. Shared by the mission-control and sessions pages.
"use strict";

// Software WebGL in the same page (or a same-site iframe) blocks this page's main thread for tens of ms per
// frame and would delay the e-stop. Browsers isolate by site (host name), not port, so the views are opened on
// another name of this server (the server says which: localhost for 127.0.0.1, its address for its name, ...);
// if this browser cannot reach that name, on this page's own.
// Returns {url(port), crossSite} where url gives the view's address with this login's token.
async function sceneAccess() {
  const response = await fetch("/api/scene");
  if (!response.ok) return null;
  const scene = await response.json();
  const address = (host, port) => `${location.protocol}//${host}:${port}/s/${scene.token}/`;
  const anyPort = scene.ports.full || scene.ports.light || scene.ports.replay;
  let host = scene.host;
  if (anyPort && host !== location.hostname && !(await reachable(address(host, anyPort)))) host = location.hostname;
  return { ports: scene.ports, crossSite: host !== location.hostname, url: (port) => address(host, port) };
}

async function reachable(url) {
  const controller = new AbortController();
  const timer = setTimeout(() => controller.abort(), 3000);
  try {
    await fetch(url, { mode: "no-cors", cache: "no-store", signal: controller.signal });
    return true;
  } catch (e) {
    return false;
  } finally {
    clearTimeout(timer);
  }
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
