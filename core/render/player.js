// Episode player: draws evaluated episodes' compact traces (core.render.episode_trace) on canvases, world y
// up, with play/pause, a time slider and frame steps. One pane per trace: .pane[data-trace] fetches it (the
// dashboard: GET /v1/evaluations/ID/episodes/S/SEED), .pane[data-trace-script] reads it from the JSON script
// element of that id (a standalone page: core.render.player). The episode page has one pane, a side-by-side
// player two, on one clock (a pane whose episode ended shows its last frame). State for tests and links:
// #player[data-frame, data-step, data-ready] and each .pane[data-frame]; a pane's .event shows its collision
// from its step on.
"use strict";
(function () {
  const root = document.getElementById("player");
  if (!root) return;
  const slider = document.getElementById("slider");
  const playBtn = document.getElementById("play");
  const clock = document.getElementById("clock");
  const PLAN_S = 2.0; // the current command held this long: the drawn plan
  let timeline = [], frame = 0, timer = null, tick = 0.1;

  function authHeaders() {
    const t = sessionStorage.getItem("foresight-token");
    return t ? {"Authorization": "Bearer " + t} : {};
  }

  // one trace on one canvas
  function Scene(pane) {
    const canvas = pane.querySelector("canvas");
    const ctx = canvas.getContext("2d");
    const eventBox = pane.querySelector(".event");
    const facts = pane.querySelector(".facts");
    const status = pane.querySelector(".status");
    let tr = null;

    // world -> canvas (y up), fitted to the map with a margin
    let scale = 1, ox = 0, oy = 0;
    function fit() {
      const m = 20, w = tr.map.width, h = tr.map.height;
      scale = Math.min((canvas.width - 2 * m) / w, (canvas.height - 2 * m) / h);
      ox = (canvas.width - w * scale) / 2;
      oy = (canvas.height - h * scale) / 2;
    }
    const X = (x) => ox + x * scale;
    const Y = (y) => canvas.height - (oy + y * scale);

    function circle(x, y, r, fill, stroke) {
      ctx.beginPath();
      ctx.arc(X(x), Y(y), r * scale, 0, 2 * Math.PI);
      if (fill) { ctx.fillStyle = fill; ctx.fill(); }
      if (stroke) { ctx.strokeStyle = stroke; ctx.stroke(); }
    }
    function line(points, color, width, dash) {
      if (points.length < 2) return;
      ctx.beginPath();
      ctx.setLineDash(dash || []);
      ctx.moveTo(X(points[0][0]), Y(points[0][1]));
      for (const p of points.slice(1)) ctx.lineTo(X(p[0]), Y(p[1]));
      ctx.strokeStyle = color;
      ctx.lineWidth = width || 1;
      ctx.stroke();
      ctx.setLineDash([]);
      ctx.lineWidth = 1;
    }

    function forecastAt(step) {
      // the latest forecast made at or before this step, within a second of it
      let best = null;
      for (const f of tr.forecasts) {
        if (f.step <= step && step - f.step <= Math.round(1.0 / tr.dt)) best = f;
      }
      return best;
    }

    function plan(pose, cmd) {
      let [x, y, th] = pose, pts = [[x, y]];
      const dt = 0.1;
      for (let t = 0; t < PLAN_S; t += dt) {
        x += cmd[0] * Math.cos(th) * dt; y += cmd[0] * Math.sin(th) * dt; th += cmd[1] * dt;
        pts.push([x, y]);
      }
      return pts;
    }

    function frameAt(step) { // this trace's last frame at or before the step
      let i = 0;
      while (i + 1 < tr.frames.length && tr.frames[i + 1] <= step) i++;
      return i;
    }

    function draw(at) {
      const k = frameAt(at), step = tr.frames[k];
      const hit = tr.collision && step >= tr.collision.step ? tr.collision : null;
      ctx.clearRect(0, 0, canvas.width, canvas.height);
      ctx.strokeStyle = "#57606a";
      ctx.strokeRect(X(0), Y(tr.map.height), tr.map.width * scale, tr.map.height * scale);
      for (const poly of tr.map.obstacles) {
        ctx.beginPath();
        ctx.moveTo(X(poly[0][0]), Y(poly[0][1]));
        for (const p of poly.slice(1)) ctx.lineTo(X(p[0]), Y(p[1]));
        ctx.closePath();
        ctx.fillStyle = "#afb8c1";
        ctx.fill();
      }
      line(tr.route, "#8c959f", 1, [4, 4]);
      circle(tr.goal[0], tr.goal[1], tr.goal_tolerance, "rgba(26,127,55,0.15)", "#1a7f37");
      circle(tr.goal[0], tr.goal[1], 0.15, "#1a7f37");
      line(tr.robot.slice(0, k + 1).map((r) => [r[0], r[1]]), "rgba(9,105,218,0.45)", 2);
      const f = forecastAt(step);
      const peds = tr.peds[k];
      if (f) {
        const now = new Map(peds.map((p) => [p[0], p]));
        f.ids.forEach((id, i) => {
          const p = now.get(id);
          if (f.sigma) { // 1-sigma discs along the forecast: its spread, as the planner used it
            f.positions[i].forEach((q, j) => circle(q[0], q[1], f.sigma[i][j], "rgba(191,135,0,0.08)", null));
          }
          line((p ? [[p[1], p[2]]] : []).concat(f.positions[i]), "#bf8700", 1.5);
        });
      }
      ctx.font = "11px sans-serif";
      for (const [id, x, y] of peds) {
        const struck = hit && hit.ped_id === id;
        circle(x, y, tr.ped_radius, struck ? "rgba(207,34,46,0.5)" : "rgba(140,149,159,0.45)", struck ? "#cf222e" : "#57606a");
        ctx.fillStyle = "#24292f";
        ctx.fillText(String(id), X(x) + tr.ped_radius * scale + 2, Y(y) - 2);
      }
      const r = tr.robot[k];
      line(plan(r, tr.command[k]), "#8250df", 2);
      circle(r[0], r[1], tr.robot_radius, "rgba(9,105,218,0.35)", "#0969da");
      line([[r[0], r[1]], [r[0] + 1.6 * tr.robot_radius * Math.cos(r[2]), r[1] + 1.6 * tr.robot_radius * Math.sin(r[2])]],
           "#0969da", 2.5);
      if (hit && hit.point) {
        const [cx, cy] = [X(hit.point[0]), Y(hit.point[1])];
        ctx.strokeStyle = "#cf222e"; ctx.lineWidth = 3;
        ctx.beginPath(); ctx.moveTo(cx - 8, cy - 8); ctx.lineTo(cx + 8, cy + 8);
        ctx.moveTo(cx + 8, cy - 8); ctx.lineTo(cx - 8, cy + 8); ctx.stroke(); ctx.lineWidth = 1;
      }
      status.textContent = "step " + step + "/" + tr.steps + (at > tr.steps ? " (ended: " + tr.outcome + ")" : "") +
        " · v " + r[3].toFixed(2) + " m/s · ω " + r[4].toFixed(2) + " rad/s";
      eventBox.hidden = !hit;
      eventBox.className = "event verdict v-failed_gate";
      eventBox.textContent = hit ? "collision (" + hit.kind + (hit.ped_id != null ? ", pedestrian " + hit.ped_id : "") +
        ") at step " + hit.step : "";
      pane.dataset.frame = String(k);
    }

    function load(data) {
      tr = data;
      fit();
      facts.textContent = tr.planner + " · outcome " + tr.outcome + (tr.label ? " (" + tr.label + ")" : "") +
        " · " + tr.steps + " steps of " + tr.dt + " s" + (tr.stride > 1 ? " (every " + tr.stride + "th shown)" : "") +
        " · robot radius " + tr.robot_radius + " m, goal tolerance " + tr.goal_tolerance + " m" +
        (tr.forecasts.length ? " · " + tr.forecasts.length + " logged forecasts" +
          (tr.forecasts[0].sigma ? " with their spread (1σ discs)" : "") : " · no forecasts recorded");
      return tr;
    }

    function fail(err) {
      facts.textContent = "could not load the trace: " + err.message;
      facts.classList.add("error");
    }

    return {load, draw, fail, trace: () => tr};
  }

  const scenes = Array.from(root.querySelectorAll(".pane")).map((pane) => ({pane, scene: Scene(pane)}));

  function draw() {
    const step = timeline[frame];
    for (const {scene} of scenes) scene.draw(step);
    slider.value = String(frame);
    clock.textContent = "t = " + (step * tick).toFixed(1) + " s · step " + step;
    root.dataset.frame = String(frame);
    root.dataset.step = String(step);
  }

  function go(i) {
    frame = Math.max(0, Math.min(timeline.length - 1, i));
    draw();
  }
  function pause() {
    clearInterval(timer); timer = null; playBtn.textContent = "play";
  }
  function play() {
    if (frame >= timeline.length - 1) go(0);
    playBtn.textContent = "pause";
    const every = timeline.length > 1 ? timeline[1] - timeline[0] : 1;
    timer = setInterval(function () {
      if (frame >= timeline.length - 1) { pause(); return; }
      go(frame + 1);
    }, 1000 * tick * every);
  }

  playBtn.addEventListener("click", () => (timer ? pause() : play()));
  document.getElementById("back").addEventListener("click", () => { pause(); go(frame - 1); });
  document.getElementById("fwd").addEventListener("click", () => { pause(); go(frame + 1); });
  slider.addEventListener("input", () => { pause(); go(Number(slider.value)); });
  document.addEventListener("keydown", (e) => {
    if (e.key === "ArrowLeft") { pause(); go(frame - 1); }
    else if (e.key === "ArrowRight") { pause(); go(frame + 1); }
    else if (e.key === " ") { e.preventDefault(); timer ? pause() : play(); }
  });

  function fetchTrace(url) {
    return fetch(url, {headers: authHeaders()}).then(async (resp) => {
      if (!resp.ok) throw new Error(resp.status + ": " + (await resp.text()));
      return resp.json();
    });
  }

  function paneTrace(pane) {
    if (pane.dataset.traceScript) {
      return Promise.resolve().then(() => JSON.parse(document.getElementById(pane.dataset.traceScript).textContent));
    }
    return fetchTrace(pane.dataset.trace);
  }

  Promise.allSettled(scenes.map(({pane}) => paneTrace(pane))).then((got) => {
    got.forEach((g, i) => (g.status === "fulfilled" ? scenes[i].scene.load(g.value) : scenes[i].scene.fail(g.reason)));
    const loaded = scenes.filter(({scene}) => scene.trace());
    if (loaded.length < scenes.length) return; // every pane says what failed; no clock without all of them
    // the clock runs over the longest episode's frames; the others hold their last frame once ended
    const longest = loaded.map(({scene}) => scene.trace()).reduce((a, b) => (b.steps > a.steps ? b : a));
    timeline = longest.frames;
    tick = longest.dt;
    slider.max = String(timeline.length - 1);
    go(0);
    downloads(loaded[0]);
    root.dataset.ready = "1";
  });

  // #download-trace saves the loaded trace as JSON, #download-frame the canvas as PNG (a page that has them)
  function save(blob, name) {
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = name;
    document.body.appendChild(a);
    a.click();
    setTimeout(() => { URL.revokeObjectURL(a.href); a.remove(); }, 0);
  }

  function downloads(first) {
    const traceBtn = document.getElementById("download-trace");
    const frameBtn = document.getElementById("download-frame");
    const name = root.dataset.name || "episode";
    if (traceBtn) {
      traceBtn.disabled = false;
      traceBtn.addEventListener("click", () =>
        save(new Blob([JSON.stringify(first.scene.trace())], {type: "application/json"}), name + ".json"));
    }
    if (frameBtn) {
      frameBtn.disabled = false;
      frameBtn.addEventListener("click", () =>
        first.pane.querySelector("canvas").toBlob((b) => save(b, `${name}_step${root.dataset.step}.png`), "image/png"));
    }
  }
})();
