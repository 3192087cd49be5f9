// liftd live view: one WebSocket (/ws), values keyed by ADS symbol name. No library, no other host.
"use strict";
(() => {
  const STATES = { 3: "READY", 4: "ACTIVE", 5: "HOLD", 6: "ERROR" };
  const PHASES = ["none", "up", "down", "done", "direct", "hold at POS_LIMIT", "coupled"];
  const COLORS = { advanced: "#d32f2f", lifting: "#7b1fa2", direct: "#ef6c00" };
  let ws = null, hello = null, mode = "live", objects = {}, values = {}, els = {};
  let history = [], geometry = [], extras = {}, missing = new Set(), nextId = 1, dirty = true;
  const pulsed = new Set();  // channels ("ch1") with a lift flag TRUE since the last sample
  const $ = (sel, root = document) => root.querySelector(sel);

  function fmt(o, v) {
    if (v === null || v === undefined) return "—";
    if (o.type === "BOOLEAN") return v ? "TRUE" : "FALSE";
    const name = o.symbol.split(".").pop();
    if (name === "state") return `${STATES[v] || v} (${v})`;
    if (name === "lift_phase") return `${PHASES[v] || v} (${v})`;
    if (o.unit === "0.1 µm") return `${(v / 1e4).toFixed(3)} mm`;
    if (o.unit === "0.1 %") return `${(v / 10).toFixed(1)} %`;
    if (o.unit === "µm/s") return `${(v / 1e3).toFixed(1)} mm/s`;
    if (o.unit === "µs") return `${Number(v).toFixed(1)} µs`;
    return String(v);
  }

  function valueCell(sym) {
    const o = objects[sym];
    const span = document.createElement("span");
    span.className = "val" + (o && o.type === "BOOLEAN" ? " bool" : "");
    span.dataset.symbol = sym;
    if (o) span.title = `${sym} [${o.unit}] ${o.comment}`;
    (els[sym] = els[sym] || []).push(span);
    return span;
  }

  function row(table, label, sym) {
    const tr = table.insertRow();
    const k = tr.insertCell(); k.className = "k"; k.textContent = label;
    tr.insertCell().appendChild(valueCell(sym));
  }

  function show(sym) {
    const o = objects[sym], v = values[sym], list = els[sym];
    if (!list) return;
    for (const el of list) {
      const absent = missing.has(sym) || v === null || v === undefined;
      if (el.tagName === "INPUT") {
        el.dataset.value = absent ? "" : String(v);
        if (el.type === "checkbox") el.checked = !!v; else if (document.activeElement !== el) el.value = v;
        continue;
      }
      const text = absent ? "" : (o.type === "BOOLEAN" ? String(!!v) : String(v));
      if (el.dataset.value === text && !absent) continue;
      el.dataset.value = text;
      el.classList.toggle("missing", absent);
      if (absent) el.dataset.missing = "true"; else delete el.dataset.missing;
      el.textContent = fmt(o, absent ? null : v);
      // a TRUE that lasts one update still catches the eye (no forced layout: Web Animations)
      if (o.type === "BOOLEAN" && v && el.animate) el.animate([{ background: "#ffcdd2" }, { background: "transparent" }], 400);
    }
  }

  function build() {
    const main = $("#channels"); main.textContent = "";
    els = {};
    objects = {};
    for (const o of hello.objects) objects[o.symbol] = o;
    for (const ch of hello.channels) {
      const node = $("#channel-template").content.firstElementChild.cloneNode(true);
      node.dataset.channel = ch.id;
      $(".ch-title", node).textContent = `channel ${ch.id} — axes ${ch.axes.join(", ")}, lift axis ${ch.lift_axis}, ${ch.method}`;
      const g = `GEO.ch${ch.id}.`;
      const chan = $(".chan", node);
      for (const [label, name] of [["state", "state"], ["line", "line"], ["block", "block"],
          ["override requested", "override_requested"], ["override in effect", "override"],
          ["override_max", "override_max"], ["feed hold", "feed_hold"], ["path velocity", "path_velocity"],
          ["block max velocity", "max_path_velocity"], ["error id", "error_id"], ["error line", "error_line"],
          ["M pending", "m_pending"]]) row(chan, label, g + name);
      const err = chan.insertRow();
      err.insertCell().textContent = "error text"; err.cells[0].className = "k";
      err.insertCell().className = "error-text";
      const body = $(".axes tbody", node);
      for (const ax of ch.axes) {
        const tr = body.insertRow();
        tr.insertCell().textContent = ax;
        for (const name of ["command_position", "lift_active", "lift_suppressed", "lift_phase", "lift_count"])
          tr.insertCell().appendChild(valueCell(`${g}${ax}.${name}`));
      }
      setupControl(node, ch.id);
      main.appendChild(node);
    }
    const loop = $("#loop"); loop.textContent = "";
    const ads = $("#ads"); ads.textContent = "";
    for (const o of hello.objects) {
      if (o.symbol === "GEO.cycle" || o.symbol.startsWith("GEO.timing.")) row(loop, o.symbol.replace("GEO.timing.", ""), o.symbol);
      else if (o.symbol.startsWith("GEO.ads.")) row(ads, o.symbol.replace("GEO.ads.", ""), o.symbol);
    }
  }

  function setupControl(node, id) {
    const panel = $(".control", node), c = hello.control || {};
    if (!c.enabled) { panel.hidden = true; panel.remove(); return; }
    panel.hidden = false;
    panel.classList.toggle("locked", !c.authed);
    const p = `PLC.ch${id}.`;
    const slider = $(".override", panel), hold = $(".feed-hold", panel), out = $(".override-out", panel);
    slider.dataset.symbol = p + "override"; hold.dataset.symbol = p + "feed_hold";
    (els[p + "override"] = els[p + "override"] || []).push(slider);
    (els[p + "feed_hold"] = els[p + "feed_hold"] || []).push(hold);
    let timer = null;
    slider.addEventListener("input", () => {
      out.textContent = `${(slider.value / 10).toFixed(1)} %`;
      clearTimeout(timer);
      timer = setTimeout(() => write(p + "override", Number(slider.value), panel), 60);
    });
    hold.addEventListener("change", () => write(p + "feed_hold", hold.checked, panel));
    for (const b of panel.querySelectorAll(".cmd")) {
      b.dataset.symbol = p + b.dataset.cmd;
      b.addEventListener("click", () => write(p + b.dataset.cmd, true, panel));
    }
    $(".auth", panel).addEventListener("submit", (e) => {
      e.preventDefault();
      const token = $(".token", panel).value;
      sessionStorage.setItem("liftd-token", token);
      send({ op: "auth", token });
    });
    const saved = sessionStorage.getItem("liftd-token");
    if (saved && !c.authed) send({ op: "auth", token: saved });
  }

  function write(symbol, value, panel) {
    const id = nextId++;
    send({ op: "write", id, symbol, value });
    $(".result", panel).textContent = `${symbol} := ${value} …`;
  }

  function send(msg) { if (ws && ws.readyState === 1) ws.send(JSON.stringify(msg)); }

  function applyValues(c) {
    for (const sym in c) { values[sym] = c[sym]; show(sym); }
  }

  // A lift flag's changes are shown one after another, each painted: a range of one GEO
  // cycle arrives as TRUE and FALSE in one update (the feed's pulse), and applied in one
  // go the browser would never paint the TRUE. A value with another behind it stays HOLD_MS
  // (TRUE) or GAP_MS (the FALSE between two ranges). A range shorter than two updates may
  // also straddle one, its FALSE in the update after its TRUE's: such a FALSE waits for
  // HOLD_MS after the TRUE too. A flag that lasts longer is shown as it comes.
  const HOLD_MS = 150, GAP_MS = 50, QUEUED = 16;
  const held = {};  // symbol → {queue, until, shownAt, update, timer}
  let updates = 0;  // the feed's updates applied (one per frame of a `frames` message)
  const isFlag = (sym) => sym.endsWith(".lift_active") || sym.endsWith(".lift_suppressed");

  function queueFlag(sym, v) {
    const h = held[sym] || (held[sym] = { queue: [], until: 0, shownAt: 0, update: -2, timer: null });
    if (v) pulsed.add(sym.split(".")[1]);  // the Z plot shades it at the next sample
    if (!v && values[sym] && !h.queue.length && updates - h.update <= 1) h.until = Math.max(h.until, h.shownAt + HOLD_MS);
    if (v) h.update = updates;  // the update a range's TRUE came in
    h.queue.push(v);
    if (h.queue.length > QUEUED) h.queue.splice(0, h.queue.length - QUEUED);
    drain(sym);
  }

  function drain(sym) {
    const h = held[sym];
    const now = performance.now();
    if (now < h.until) {
      if (!h.timer) h.timer = setTimeout(() => { h.timer = null; drain(sym); }, h.until - now);
      return;
    }
    if (!h.queue.length) return;
    const v = h.queue.shift();
    values[sym] = v; show(sym);
    h.shownAt = now;
    h.until = h.queue.length ? now + (v ? HOLD_MS : GAP_MS) : 0;
    if (h.queue.length) drain(sym);
  }

  function applyFrames(list) {
    for (const f of list) {
      updates++;
      const c = {};
      for (const sym in f.c) if (isFlag(sym)) queueFlag(sym, f.c[sym]); else c[sym] = f.c[sym];
      applyValues(c); applyExtras(f.x);
    }
  }

  function sample(times) {
    if (!hello || !times) return;
    hello.channels.forEach((ch, i) => {
      const g = `GEO.ch${ch.id}.`;
      const pos = ch.axes.map((a) => (values[`${g}${a}.command_position`] || 0) / 1e4);
      const on = pulsed.has(`ch${ch.id}`) || ch.axes.some((a) => values[`${g}${a}.lift_active`] || values[`${g}${a}.lift_suppressed`]);
      const h = history[i] || (history[i] = []);
      const t = times[i];
      if (h.length && t < h[h.length - 1][0]) h.length = 0;
      h.push([t, pos, on]);
      while (h.length && t - h[0][0] > 10) h.shift();
    });
    pulsed.clear();
  }

  function applyExtras(x) {
    if (!x) return;
    if (x.geometry) drawings(x.geometry);
    for (const k of ["range", "text", "peers", "geo", "trace", "error"]) if (k in x) extras[k] = x[k];
    if (x.events && x.events.length) addEvents(x.events);
    if (x.t) sample(x.t);
    if ("geo" in x) {
      const g = $("#geo"); g.textContent = `GEO: ${x.geo}`;
      g.className = "badge " + (x.geo === "down" ? "bad" : "good");
    }
    if ("peers" in x) peers(x.peers);
    if ("trace" in x) timeline(x.trace);
    if ("text" in x || "range" in x || "error" in x) notes();
    dirty = true;
  }

  // the program's drawing per channel: GET /drawing/<index>/<version>, once per version
  const drawingAt = [];  // the version each channel's drawing has (or is being fetched at)
  function drawings(versions) {
    versions.forEach((v, i) => {
      if (v === null) { geometry[i] = null; drawingAt[i] = null; dirty = true; return; }
      if (drawingAt[i] === v) return;
      drawingAt[i] = v;
      fetch(`/drawing/${i}/${v}`).then((r) => r.ok ? r.json() : null).then((g) => {
        if (g && drawingAt[i] === v) { geometry[i] = g; dirty = true; }
      }).catch(() => { if (drawingAt[i] === v) drawingAt[i] = undefined; });
    });
  }

  function addEvents(list) {
    const ol = $("#events");
    for (const e of list) {
      const li = document.createElement("li");
      li.textContent = `${e.t.toFixed(3)} s ${e.channel ? "ch" + e.channel + " " : ""}${e.name} line ${e.line}` +
        (e.value ? ` value ${e.value}` : "") + (e.text ? ` ${e.text}` : "");
      ol.insertBefore(li, ol.firstChild);
    }
    while (ol.children.length > 50) ol.lastChild.remove();
  }

  function peers(list) {
    const body = $("#peers tbody"); body.textContent = "";
    for (const p of list || []) {
      const tr = body.insertRow();
      for (const k of ["peer", "net_id", "requests", "notifications"]) tr.insertCell().textContent = p[k];
    }
  }

  function notes() {
    for (const node of document.querySelectorAll(".channel")) {
      const id = node.dataset.channel;
      $(".block-text code", node).textContent = (extras.text || {})[id] || "";
      $(".error-text", node).textContent = (extras.error || {})[id] || "";
      const r = (extras.range || {})[id];
      $(".range-note", node).textContent = r ? `open range N${r.start_line}–N${r.end_line} (${r.method}${r.suppressed ? ", suppressed" : ""}): POS ${r.pos} mm, POS_LIMIT ${r.pos_limit} mm` : "no range open";
    }
  }

  function timeline(tr) {
    if (!tr) return;
    const bar = $("#timeline"); bar.hidden = false;
    const scrub = $("#scrub");
    if (document.activeElement !== scrub) scrub.value = Math.round(1000 * (tr.t - tr.t0) / Math.max(1e-9, tr.t1 - tr.t0));
    $("#clock").textContent = `${tr.t.toFixed(3)} / ${tr.t1.toFixed(3)} s`;
    $("#play").textContent = tr.playing ? "pause" : "play";
    $("#speed").value = String(tr.speed);
  }

  function onMessage(ev) {
    let m;
    try { m = JSON.parse(ev.data); } catch (e) { return; }
    if (m.op === "hello") {
      // again after a seek or when this page fell behind: the same page, new values
      const same = hello && hello.mode === m.mode &&
        JSON.stringify([hello.objects, hello.channels, hello.control]) === JSON.stringify([m.objects, m.channels, m.control]);
      hello = m; mode = m.mode; missing = new Set(m.missing || []);
      $("#mode").textContent = mode === "trace" ? "trace replay" : "GEO task, live";
      const c = m.control || {};
      $("#control-state").textContent = c.enabled ? "control: token" : `read only`;
      $("#control-state").title = c.detail || "";
      values = {}; history = m.state.history || []; extras = {};
      for (const sym in held) { clearTimeout(held[sym].timer); delete held[sym]; }
      if (!same) build();
      $("#events").textContent = "";
      applyValues(m.state.values);
      for (const sym in objects) if (!(sym in m.state.values)) show(sym);
      applyExtras(m.state.x);
      document.body.dataset.mode = mode;
      document.body.dataset.ready = "true";
    } else if (m.op === "frames") {
      applyFrames(m.frames);
    } else if (m.op === "auth") {
      for (const p of document.querySelectorAll(".control")) {
        p.classList.toggle("locked", !m.ok);
        const r = $(".result", p); r.textContent = m.detail; r.classList.toggle("bad", !m.ok);
      }
      if (!m.ok) sessionStorage.removeItem("liftd-token");
    } else if (m.op === "result") {
      for (const p of document.querySelectorAll(".control")) {
        const r = $(".result", p);
        r.textContent = m.ok ? `${m.symbol} := ${m.value}: taken` : `refused: ${m.detail}`;
        r.classList.toggle("bad", !m.ok);
      }
    } else if (m.op === "trace") {
      timeline(m);
    } else if (m.op === "error") {
      console.warn("liftd:", m.detail);
    }
  }

  function connect() {
    const link = $("#link");
    ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
    ws.onopen = () => { link.textContent = "connected"; link.className = "badge good"; };
    ws.onmessage = onMessage;
    ws.onclose = () => {
      link.textContent = "disconnected: retrying"; link.className = "badge bad";
      document.body.dataset.ready = "false";
      setTimeout(connect, 1000);
    };
  }

  // -- drawing ------------------------------------------------------------------------------------
  function fit(pts, w, h, pad) {
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    for (const [x, y] of pts) { x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y); }
    if (!isFinite(x0)) { x0 = 0; x1 = 1; y0 = 0; y1 = 1; }
    const s = Math.min((w - 2 * pad) / Math.max(x1 - x0, 1e-6), (h - 2 * pad) / Math.max(y1 - y0, 1e-6));
    return ([x, y]) => [pad + (x - x0) * s, h - pad - (y - y0) * s];
  }

  function line(ctx, pts, map) {
    ctx.beginPath();
    pts.forEach((p, i) => { const [x, y] = map(p); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
    ctx.stroke();
  }

  function drawXY(node, i) {
    const cv = $(".xy", node), ctx = cv.getContext("2d"), geo = geometry[i], h = history[i] || [];
    ctx.clearRect(0, 0, cv.width, cv.height);
    const trail = h.map((s) => [s[1][0], s[1][1]]);
    const path = geo && geo.path && geo.path.length ? geo.path : trail;
    const map = fit(path.concat(trail.slice(-1)), cv.width, cv.height, 16);
    ctx.lineWidth = 1; ctx.strokeStyle = "#9aa4ae"; line(ctx, path, map);
    $(".geo-note", node).textContent = geo ? (geo.error || "") : "path: being prepared (or no program)";
    ctx.strokeStyle = "rgba(21,101,192,0.35)"; ctx.lineWidth = 6; line(ctx, trail, map);
    if (geo) for (const [i0, i1, method] of geo.ranges) {  // spans of the drawn path
      ctx.strokeStyle = COLORS[method] || "#d32f2f"; ctx.lineWidth = 2;
      ctx.setLineDash(method === "direct" ? [5, 4] : []); line(ctx, path.slice(i0, i1 + 1), map);
    }
    ctx.setLineDash([]);
    if (trail.length) {
      const [x, y] = map(trail[trail.length - 1]);
      ctx.fillStyle = "#1565c0"; ctx.beginPath(); ctx.arc(x, y, 5, 0, 2 * Math.PI); ctx.fill();
    }
  }

  function drawZ(node, i, ch) {
    const cv = $(".zt", node), ctx = cv.getContext("2d"), h = history[i] || [];
    const W = cv.width, H = cv.height, pad = 30;
    ctx.clearRect(0, 0, W, H);
    if (!h.length) return;
    const r = (extras.range || {})[ch.id];
    const zi = Math.max(0, ch.axes.indexOf(r ? r.axis : ch.lift_axis));
    const t1 = h[h.length - 1][0], t0 = t1 - 10;
    let z0 = Infinity, z1 = -Infinity;
    for (const s of h) { z0 = Math.min(z0, s[1][zi]); z1 = Math.max(z1, s[1][zi]); }
    if (r) { z0 = Math.min(z0, r.pos, r.pos_limit); z1 = Math.max(z1, r.pos, r.pos_limit); }
    if (z1 - z0 < 1) { z1 += 0.5; z0 -= 0.5; }
    const X = (t) => pad + (t - t0) / 10 * (W - 2 * pad), Y = (z) => H - pad - (z - z0) / (z1 - z0) * (H - 2 * pad);
    ctx.fillStyle = "rgba(198,40,40,0.10)";
    for (let k = 1; k < h.length; k++) if (h[k][2]) ctx.fillRect(X(h[k - 1][0]), pad, Math.max(2, X(h[k][0]) - X(h[k - 1][0])), H - 2 * pad);
    ctx.strokeStyle = "#ccc"; ctx.strokeRect(pad, pad, W - 2 * pad, H - 2 * pad);
    ctx.fillStyle = "#555"; ctx.font = "11px sans-serif";
    ctx.fillText(`${z1.toFixed(1)} mm`, 2, pad - 4); ctx.fillText(`${z0.toFixed(1)} mm`, 2, H - pad + 12);
    ctx.fillText("−10 s", pad, H - 6); ctx.fillText("now", W - pad - 20, H - 6);
    if (r) {
      ctx.setLineDash([6, 4]);
      ctx.strokeStyle = "#000"; ctx.beginPath(); ctx.moveTo(pad, Y(r.pos_limit)); ctx.lineTo(W - pad, Y(r.pos_limit)); ctx.stroke();
      ctx.fillStyle = "#000"; ctx.fillText("POS_LIMIT", W - pad - 60, Y(r.pos_limit) - 3);
      ctx.strokeStyle = "#2e7d32"; ctx.beginPath(); ctx.moveTo(pad, Y(r.pos)); ctx.lineTo(W - pad, Y(r.pos)); ctx.stroke();
      ctx.fillStyle = "#2e7d32"; ctx.fillText("POS", W - pad - 30, Y(r.pos) - 3);
      ctx.setLineDash([]);
    }
    ctx.strokeStyle = "#c62828"; ctx.lineWidth = 2;
    line(ctx, h.map((s) => [s[0], s[1][zi]]), ([t, z]) => [X(t), Y(z)]);
    ctx.lineWidth = 1;
    const phase = values[`GEO.ch${ch.id}.${ch.axes[zi]}.lift_phase`];
    ctx.fillStyle = "#333"; ctx.font = "12px sans-serif";
    ctx.fillText(`${ch.axes[zi]} ${((h[h.length - 1][1][zi]) || 0).toFixed(2)} mm, lift phase: ${phase == null ? "—" : PHASES[phase] || phase}`, pad + 6, pad + 14);
  }

  let drawn = 0;
  function frame(now) {
    if (dirty && hello && now - drawn >= 100) {  // the figures at 10 Hz: the values stay at 50
      dirty = false;
      drawn = now;
      document.querySelectorAll(".channel").forEach((node, i) => { drawXY(node, i); drawZ(node, i, hello.channels[i]); });
    }
    requestAnimationFrame(frame);
  }

  function setupTimeline() {
    $("#play").addEventListener("click", () => send({ op: extras.trace && extras.trace.playing ? "pause" : "play" }));
    $("#scrub").addEventListener("input", (e) => {
      const tr = extras.trace; if (!tr) return;
      send({ op: "seek", t: tr.t0 + (tr.t1 - tr.t0) * Number(e.target.value) / 1000 });
    });
    $("#speed").addEventListener("change", (e) => send({ op: "speed", x: Number(e.target.value) }));
  }

  setupTimeline();
  connect();
  requestAnimationFrame(frame);
})();
