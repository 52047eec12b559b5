// Foresight dashboard: token prompt, write actions through the JSON API, live rows and the job's event stream.
"use strict";
(function () {
  const KEY = "foresight-token";
  const COOKIE = "foresight_token";

  function setToken(t) {
    sessionStorage.setItem(KEY, t);
    // session cookie: lets pages, images and reports load when the server closes reads
    document.cookie = COOKIE + "=" + encodeURIComponent(t) + "; path=/; SameSite=Strict";
    markToken();
  }
  function clearToken() {
    sessionStorage.removeItem(KEY);
    document.cookie = COOKIE + "=; path=/; max-age=0; SameSite=Strict";
    markToken();
  }
  function token(ask) {
    let t = sessionStorage.getItem(KEY);
    if (!t && ask) {
      t = (window.prompt("API token (FORESIGHT_API_TOKEN); kept for this browser session") || "").trim();
      if (t) setToken(t);
    }
    return t || null;
  }
  function headers(extra) {
    const h = Object.assign({}, extra || {});
    const t = token(false);
    if (t) h["Authorization"] = "Bearer " + t;
    return h;
  }
  function markToken() {
    const b = document.getElementById("token-btn");
    if (!b) return;
    const set = !!sessionStorage.getItem(KEY);
    b.classList.toggle("set", set);
    b.textContent = set ? "token ✓" : "token";
  }
  function flash(text, bad) {
    const f = document.getElementById("flash");
    if (!f) return;
    f.textContent = text;
    f.classList.toggle("bad", !!bad);
    f.hidden = false;
    clearTimeout(flash.timer);
    flash.timer = setTimeout(function () { f.hidden = true; }, bad ? 8000 : 3000);
  }
  async function detail(resp) {
    try {
      const body = await resp.json();
      return typeof body.detail === "string" ? body.detail : JSON.stringify(body.detail);
    } catch (e) { return resp.statusText; }
  }

  // A write call: asks for the token once; a rejected token is forgotten and asked for again (once).
  async function post(url, body) {
    for (let attempt = 0; attempt < 2; attempt++) {
      if (!token(true)) throw new Error("no token given");
      const resp = await fetch(url, {
        method: "POST", headers: headers({"Content-Type": "application/json"}),
        body: body ? body : undefined,
      });
      if (resp.status === 401 || resp.status === 403) {
        clearToken();
        flash("token rejected (" + resp.status + "): " + await detail(resp), true);
        continue;
      }
      if (!resp.ok) throw new Error(resp.status + ": " + await detail(resp));
      return resp.json();
    }
    throw new Error("token rejected");
  }

  async function refresh() {
    if (document.getElementById("job-rows")) return pollRows();
    if (document.getElementById("job-summary")) return reloadSummary();
    location.reload();
  }

  document.addEventListener("click", async function (ev) {
    const el = ev.target.closest("[data-action]");
    if (!el) return;
    const action = el.dataset.action;
    if (action === "token-reload") {  // on the token page the kept token (if any) was refused: ask anew
      clearToken();
      if (token(true)) location.reload();
      return;
    }
    if (action !== "post") return;
    if (el.dataset.confirm && !window.confirm(el.dataset.confirm)) return;
    el.disabled = true;
    try {
      const out = await post(el.dataset.url, el.dataset.body);
      if (el.dataset.open && out.id) {  // a job submitted from the page: follow it on its own page
        location.href = el.dataset.open.replace("{id}", encodeURIComponent(out.id));
        return;
      }
      flash((out.id ? out.id.substring(0, 12) + ": " : "") + (el.dataset.done || out.status || "done"));
      await refresh();
    } catch (e) {
      flash(String(e.message || e), true);
    } finally {
      el.disabled = false;
    }
  });

  // Live jobs table: the server renders the rows, the page swaps them in.
  async function pollRows() {
    const body = document.getElementById("job-rows");
    if (!body) return;
    try {
      const resp = await fetch(body.dataset.poll, {headers: headers()});
      if (resp.ok) body.innerHTML = await resp.text();
    } catch (e) { /* server restarting: keep the last rows */ }
  }

  async function reloadSummary() {
    const box = document.getElementById("job-summary");
    if (!box) return;
    const resp = await fetch(box.dataset.summary, {headers: headers()});
    if (resp.ok) box.innerHTML = await resp.text();
  }

  // The job's events (server-sent events read through fetch, so the token header can go along).
  function followEvents(pre) {
    const box = document.getElementById("job-summary");
    let last = 0;
    let ended = false;
    function line(ev) {
      const at = new Date(ev.at * 1000).toISOString().substring(11, 19);
      let text = at + "  " + ev.type.padEnd(8) + " ";
      if (ev.type === "progress" && ev.progress !== null) text += Math.round(ev.progress * 100) + " %  ";
      pre.textContent += text + (ev.message || "") + "\n";
      if (pre.textContent.length > 400000) pre.textContent = "…\n" + pre.textContent.slice(-300000);
      pre.scrollTop = pre.scrollHeight;
    }
    function progress(ev) {
      if (ev.progress === null || ev.progress === undefined) return;
      const bar = box && box.querySelector(".bar > div");
      if (bar) bar.style.width = (ev.progress * 100).toFixed(1) + "%";
      const pct = document.getElementById("job-progress");
      if (pct) pct.textContent = Math.round(ev.progress * 100) + " %";
      const msg = document.getElementById("job-message");
      if (msg && ev.message) msg.textContent = ev.message;
    }
    function handle(frame) {
      let type = "message", data = "", id = null;
      for (const row of frame.split("\n")) {
        if (row.startsWith("event:")) type = row.slice(6).trim();
        else if (row.startsWith("data:")) data += row.slice(5).trim();
        else if (row.startsWith("id:")) id = parseInt(row.slice(3).trim(), 10);
      }
      if (!data) return;
      if (id !== null) last = id;
      const ev = JSON.parse(data);
      if (type === "end") {
        ended = true;
        pre.dataset.ended = ev.status;
        reloadSummary().then(function () {
          if (box && box.dataset.final === "0") location.reload();  // artifacts and the report have landed
        });
        return;
      }
      line(ev);
      if (type === "progress") progress(ev);
      if (type === "status") reloadSummary();
    }
    async function run() {
      while (!ended) {
        try {
          const resp = await fetch(pre.dataset.events + "?after=" + last, {headers: headers({"Accept": "text/event-stream"})});
          if (!resp.ok || !resp.body) throw new Error(String(resp.status));
          const reader = resp.body.getReader();
          const decoder = new TextDecoder();
          let buf = "";
          for (;;) {
            const {value, done} = await reader.read();
            if (done) break;
            buf += decoder.decode(value, {stream: true});
            let cut;
            while ((cut = buf.indexOf("\n\n")) >= 0) {
              handle(buf.slice(0, cut));
              buf = buf.slice(cut + 2);
            }
          }
        } catch (e) { /* reconnect below */ }
        if (!ended) await new Promise(function (r) { setTimeout(r, 2000); });
      }
    }
    run();
  }

  document.addEventListener("DOMContentLoaded", function () {
    markToken();
    const b = document.getElementById("token-btn");
    if (b) b.addEventListener("click", function () {
      if (sessionStorage.getItem(KEY)) {
        if (window.confirm("Forget the API token of this session?")) clearToken();
      } else if (token(true)) flash("token kept for this session");
    });
    const rows = document.getElementById("job-rows");
    if (rows) setInterval(function () { if (!document.hidden) pollRows(); }, parseInt(rows.dataset.pollMs || "2000", 10));
    const log = document.getElementById("job-log");
    if (log) followEvents(log);
    document.querySelectorAll("iframe.report").forEach(fitFrame);
  });

  // the new-job form: each field parsed by its data-parse, empty ones left out; the API validates the spec
  document.addEventListener("submit", async function (ev) {
    const form = ev.target.closest("#job-form");
    if (!form) return;
    ev.preventDefault();
    const spec = {kind: form.dataset.kind};
    try {
      form.querySelectorAll("[data-parse]").forEach(function (el) {
        const raw = el.value.trim();
        if (raw === "") return;
        const how = el.dataset.parse;
        if (how === "int") spec[el.name] = parseInt(raw, 10);
        else if (how === "float") spec[el.name] = parseFloat(raw);
        else if (how === "bool") spec[el.name] = raw === "true";
        else if (how === "list") spec[el.name] = raw.split(",").map(function (s) { return s.trim(); }).filter(Boolean);
        else if (how === "json") {
          try { spec[el.name] = JSON.parse(raw); } catch (e) { throw new Error(el.name + ": not JSON (" + e.message + ")"); }
        } else spec[el.name] = raw;
      });
      const body = {spec: spec};
      const name = form.querySelector("[name=__name]").value.trim();
      if (name) body.name = name;
      const job = await post("/v1/jobs", JSON.stringify(body));
      location.href = "/ui/jobs/" + encodeURIComponent(job.id);
    } catch (e) {
      flash(String(e.message || e), true);
    }
  });

  // an embedded report is as tall as its page (same origin), so nothing of it is cut off or scrolls twice
  function fitFrame(frame) {
    function fit() {
      try {
        const doc = frame.contentDocument;
        if (!doc || !doc.documentElement) return;
        frame.style.height = (doc.documentElement.scrollHeight + 24) + "px";
        frame.dataset.fitted = "1";
      } catch (e) { /* another origin: keep the CSS height */ }
    }
    frame.addEventListener("load", function () {
      fit();
      frame.contentDocument.querySelectorAll("img").forEach(function (img) { img.addEventListener("load", fit); });
    });
    if (frame.contentDocument && frame.contentDocument.readyState === "complete") fit();
  }
})();
