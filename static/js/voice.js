// Push-to-talk: hold the button (or T) to record 16 kHz PCM with an AudioWorklet, release to transcribe it on
// the server; the transcript goes into the command box to confirm or edit, or runs at once when the recogniser
// is sure and "run when sure" is ticked. The robot's `say` steps are played from server-side speech synthesis.
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const RATE = 16000;
  const WORKLET = `
    class Recorder extends AudioWorkletProcessor {
      process(inputs) {
        const channel = inputs[0] && inputs[0][0];
        if (channel) this.port.postMessage(channel.slice(0));
        return true;
      }
    }
    registerProcessor("recorder", Recorder);`;
  let context = null, source = null, node = null, stream = null, chunks = [], recording = false;

  // the confidence, and why a transcript is not sure when the recogniser says why
  function howSure(data) {
    const form = data.in_grammar ? "" : ", not a known command form";
    const names = (data.unsure_names || []).map((n) => `"${n}"`).join(", ");
    const read = data.first_heard ? `; first heard as "${data.first_heard}", read as the nearest command` : "";
    return `confidence ${data.confidence.toFixed(2)}${form}${names ? `; ${names} may be a guess: check it` : ""}${read}`;
  }

  function heard(text, isError) {
    const el = $("heard");
    el.textContent = text;
    el.className = "result " + (isError ? "error" : "ok");
  }

  // The robot's own microphone: what it heard, run already when it was sure, else offered for confirmation.
  window.humanoid.onRobotHeard = (data) => {
    if (data.stop) return heard(`the robot heard a spoken stop ("${data.text}"): e-stop latched`, true);
    const sure = howSure(data);
    if (data.will_run) return heard(`the robot heard "${data.text}" (${sure}): running`, false);
    $("command-text").value = data.text;
    window.humanoid.heardAs = { text: data.text, alternatives: data.alternatives || [] };
    heard(`the robot heard "${data.text}" (${sure}): press Send to run it, or edit it first`, false);
  };

  if (!window.isSecureContext || !navigator.mediaDevices || !window.AudioWorkletNode) {
    $("ptt").disabled = true;
    heard(`The microphone needs a secure context: open this page as http://localhost:${location.port} or ` +
          `http://127.0.0.1:${location.port} (or over HTTPS). Typed commands work everywhere.`, true);
    return;
  }

  async function start() {
    if (recording) return;
    recording = true;
    chunks = [];
    $("ptt").classList.add("recording");
    heard("listening… release to send", false);
    try {
      if (!context) {
        context = new AudioContext({ sampleRate: RATE });  // the browser resamples the microphone for us
        await context.audioWorklet.addModule(URL.createObjectURL(new Blob([WORKLET], { type: "text/javascript" })));
      }
      await context.resume();
      stream = await navigator.mediaDevices.getUserMedia({ audio: { channelCount: 1, echoCancellation: true,
        noiseSuppression: true } });
      source = context.createMediaStreamSource(stream);
      node = new AudioWorkletNode(context, "recorder");
      node.port.onmessage = (ev) => { if (recording) chunks.push(ev.data); };
      source.connect(node);
    } catch (e) {
      recording = false;
      $("ptt").classList.remove("recording");
      heard("no microphone: " + e.message, true);
    }
  }

  async function stop() {
    if (!recording) return;
    recording = false;
    $("ptt").classList.remove("recording");
    if (source) source.disconnect();
    if (stream) stream.getTracks().forEach((t) => t.stop());
    const length = chunks.reduce((n, c) => n + c.length, 0);
    const pcm = new Int16Array(length);
    let offset = 0;
    for (const chunk of chunks) {
      for (let i = 0; i < chunk.length; i++) pcm[offset + i] = Math.max(-32768, Math.min(32767, Math.round(chunk[i] * 32767)));
      offset += chunk.length;
    }
    heard(`recognising ${(length / RATE).toFixed(1)} s…`, false);
    const r = await fetch("/api/speech/transcribe", { method: "POST",
      headers: { "Content-Type": `audio/L16; rate=${context.sampleRate}` }, body: pcm.buffer });
    const data = await r.json().catch(() => ({ detail: { message: r.statusText } }));
    if (!r.ok) return heard((data.detail && data.detail.message) || JSON.stringify(data.detail), true);
    window.humanoid.lastTranscript = data;
    if (data.stop_word) return heard(`heard a spoken stop${data.text ? ` ("${data.text}")` : ""}: e-stop latched`, true);
    if (!data.text) return heard("nothing recognised: try again, closer to the microphone", true);
    $("command-text").value = data.text;
    // the other wordings go with the command while its text is as heard: tried if the text cannot be planned
    window.humanoid.heardAs = { text: data.text, alternatives: data.alternatives || [] };
    const sure = howSure(data);
    if (data.auto_run && $("auto-run").checked) {
      heard(`heard "${data.text}" (${sure}): running`, false);
      $("command-form").requestSubmit();
    } else {
      heard(`heard "${data.text}" (${sure}): press Send to run it, or edit it first`, false);
      $("command-text").focus();
    }
  }

  $("ptt").addEventListener("pointerdown", (ev) => { ev.preventDefault(); start(); });
  $("ptt").addEventListener("pointerup", stop);
  $("ptt").addEventListener("pointerleave", stop);
  document.addEventListener("keydown", (ev) => {
    if ((ev.key === "t" || ev.key === "T") && !ev.repeat && document.activeElement.tagName !== "INPUT" &&
        document.activeElement.tagName !== "TEXTAREA") { ev.preventDefault(); start(); }
  });
  document.addEventListener("keyup", (ev) => { if (ev.key === "t" || ev.key === "T") stop(); });

  // The robot's voice: each `say` the robot makes, spoken in the page.
  const queue = [];
  let playing = false;
  function playNext() {
    if (playing || !queue.length) return;
    playing = true;
    const audio = new Audio("/api/speech/say.wav?text=" + encodeURIComponent(queue.shift()));
    audio.onended = audio.onerror = () => { playing = false; playNext(); };
    audio.play().catch(() => { playing = false; playNext(); });
  }
  window.humanoid.onSay = (text) => {
    if (!$("speak").checked) return;
    queue.push(text);
    playNext();
  };
})();
