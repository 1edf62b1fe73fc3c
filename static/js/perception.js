// Perception panel: the head camera with its detections (one WebSocket: a JSON header, then the JPEG of the same
// frame, so the boxes always belong to the image under them), the world memory, and the occupancy map with the
// robot's estimated pose.
"use strict";

(function () {
  const $ = (id) => document.getElementById(id);
  const camera = $("camera");
  const cctx = camera.getContext("2d");
  const map = $("map");
  const mctx = map.getContext("2d");
  const view = { frames: [], header: null, fps: 0, detections: [], mapImage: null, mapInfo: null, perception: null, loco: null };
  humanoid.camera = view;

  function connectCamera() {
    const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws/camera`);
    ws.binaryType = "blob";
    ws.onmessage = async (msg) => {
      if (typeof msg.data === "string") {
        const header = JSON.parse(msg.data);
        // The same picture again (the robot stands still): a frame all the same, with nothing to decode or draw.
        if (header.unchanged) countFrame(header);
        else view.header = header;
        return;
      }
      const header = view.header;
      if (!header) return;
      const bitmap = await createImageBitmap(msg.data); // decoded off the main thread
      drawFrame(bitmap, header);
      bitmap.close();
    };
    ws.onclose = () => setTimeout(connectCamera, 1000);
  }

  // The frame rate and sequence, shown twice a second: each change of the text is a layout and a paint of the page,
  // and an e-stop press waits behind them on this thread.
  const FPS_SHOWN_EVERY_MS = 500;
  function countFrame(header) {
    const now = performance.now();
    view.frames.push(now);
    while (view.frames.length && now - view.frames[0] > 2000) view.frames.shift();
    view.fps = view.frames.length > 1 ? (view.frames.length - 1) * 1000 / (now - view.frames[0]) : 0;
    view.seq = header.seq;
    view.detections = header.detections;
    if (view.fpsShownAt !== undefined && now - view.fpsShownAt < FPS_SHOWN_EVERY_MS) return;
    view.fpsShownAt = now;
    $("camera-fps").textContent = `${view.fps.toFixed(1)} fps shown · camera ${Number(header.camera_hz).toFixed(1)} Hz · frame ${header.seq}`;
  }

  function drawFrame(bitmap, header) {
    countFrame(header);
    const sx = camera.width / header.width, sy = camera.height / header.height;
    cctx.drawImage(bitmap, 0, 0, camera.width, camera.height);
    if ($("show-detections").checked) {
      cctx.lineWidth = 2;
      cctx.font = "12px system-ui, sans-serif";
      for (const d of header.detections) {
        const [x0, y0, x1, y1] = d.box;
        cctx.strokeStyle = "#ffd400";
        cctx.strokeRect(x0 * sx - 2, y0 * sy - 2, (x1 - x0 + 1) * sx + 4, (y1 - y0 + 1) * sy + 4);
        const text = `${d.label} ${(d.confidence * 100).toFixed(0)}% ${d.distance_m.toFixed(2)} m`;
        const w = cctx.measureText(text).width + 6;
        const ty = Math.max(0, y0 * sy - 18);
        cctx.fillStyle = "rgba(0,0,0,0.65)";
        cctx.fillRect(x0 * sx - 2, ty, w, 16);
        cctx.fillStyle = "#ffd400";
        cctx.fillText(text, x0 * sx + 1, ty + 12);
      }
    }
  }

  async function refreshMap() {
    try {
      const response = await fetch("/api/map.png", { cache: "no-store" });
      if (response.ok) {
        const [ox, oy] = response.headers.get("X-Map-Origin").split(",").map(Number);
        view.mapInfo = { ox, oy, res: Number(response.headers.get("X-Map-Resolution")), scans: Number(response.headers.get("X-Map-Scans")) };
        const bitmap = await createImageBitmap(await response.blob());
        if (view.mapImage) view.mapImage.close();
        view.mapImage = bitmap;
        view.mapVersion = (view.mapVersion || 0) + 1;
        drawMap();
      }
    } catch (e) { /* the next refresh retries */ }
    setTimeout(refreshMap, 1000);
  }

  // World (x, y) to map canvas pixels: the map image is drawn to fit, +y up.
  // Redrawn only when something on it changed (a new map, an object, the robot's pose): an unchanged canvas
  // redrawn 4 times a second is a repaint and a composite for nothing.
  let lastMapKey = "";
  function drawMap() {
    const img = view.mapImage, info = view.mapInfo;
    if (!img || !info) return;
    const pose = view.loco ? view.loco.estimated_pose.map((v) => v.toFixed(2)).join() : "";
    const objects = ((view.perception && view.perception.known_objects) || []).map((o) => o.position.join()).join(";");
    const key = `${view.mapVersion}|${pose}|${objects}`;
    if (key === lastMapKey) return;
    lastMapKey = key;
    const scale = Math.min(map.width / img.width, map.height / img.height) * 1.6; // zoom on the middle
    const w = img.width * scale, h = img.height * scale;
    const left = (map.width - w) / 2, top = (map.height - h) / 2;
    const toPx = (x, y) => [left + ((x - info.ox) / info.res) * scale, top + h - ((y - info.oy) / info.res) * scale];
    mctx.fillStyle = "#0f1317";
    mctx.fillRect(0, 0, map.width, map.height);
    mctx.imageSmoothingEnabled = false;
    mctx.drawImage(img, left, top, w, h);
    for (const o of (view.perception && view.perception.known_objects) || []) {
      const [px, py] = toPx(o.position[0], o.position[1]);
      mctx.fillStyle = "#ffd400";
      mctx.fillRect(px - 3, py - 3, 6, 6);
    }
    if (view.loco) {
      const [x, y, yaw] = view.loco.estimated_pose;
      const [px, py] = toPx(x, y);
      mctx.strokeStyle = "#3d9bff"; mctx.fillStyle = "#3d9bff"; mctx.lineWidth = 2;
      mctx.beginPath(); mctx.arc(px, py, 5, 0, 2 * Math.PI); mctx.fill();
      mctx.beginPath(); mctx.moveTo(px, py); mctx.lineTo(px + 14 * Math.cos(yaw), py - 14 * Math.sin(yaw)); mctx.stroke();
    }
    humanoid.setText("map-info", `occupancy map: ${info.scans} scans, ${(info.res * 100).toFixed(0)} cm cells (black occupied, white free)`);
  }

  let lastKnown = "";
  humanoid.renderPerception = function (p, loco) {
    view.perception = p;
    view.loco = loco;
    if (!p) { humanoid.setText("perc-status", "off"); return; }
    humanoid.setText("perc-status", p.status === "ok" ? `camera ${p.camera_hz.toFixed(1)} Hz · lidar ${p.lidar_hz.toFixed(1)} Hz` : p.status);
    humanoid.setClass("perc-status", "badge " + (p.status === "ok" ? "badge-ok" : p.status === "starting" ? "badge-warn" : "badge-err"));
    const key = JSON.stringify(p.known_objects);
    if (key !== lastKnown) {
      lastKnown = key;
      const list = $("known-objects");
      list.innerHTML = "";
      if (!p.known_objects.length) list.innerHTML = '<li class="muted">nothing seen yet</li>';
      for (const o of p.known_objects) {
        const li = document.createElement("li");
        const [x, y, z] = o.position;
        li.textContent = `${o.name}: ${o.place || "somewhere"} (${x.toFixed(2)}, ${y.toFixed(2)}, ${z.toFixed(2)}) m, seen at ${o.seen_sim_s.toFixed(1)} s`;
        list.appendChild(li);
      }
    }
  };
  setInterval(drawMap, 250);
  connectCamera();
  refreshMap();
})();
