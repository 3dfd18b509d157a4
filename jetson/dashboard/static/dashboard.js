// Pac-Man Pete's dashboard: draws what the daemon's WebSocket sends. Read-only: the only messages
// this page sends are a replay's seek/play/speed, which move this page's own cursor.
"use strict";

(function () {
  const $ = (id) => document.getElementById(id);
  const D = {
    hello: null, state: null, prev: null, frame: null, jetson: null, cursor: null,
    drawn: { robot: null, partner: null, claim: null, rings: { seen: 0, remembered: 0, forgotten: 0 }, goals: 0, robots_seen: 0 },
    received: { state: 0, frame: 0, jetson: 0 },
    rates: { state_hz: 0, frame_hz: 0 },
    linkRates: { up_hz: null, down_hz: null },
    commands: [],
    trail: [],
    cameraDrawn: 0,
  };
  window.peteDashboard = D;
  const arrivals = { state: [], frame: [] };

  function fmt(v, nd) { return v === null || v === undefined ? "-" : Number(v).toFixed(nd); }
  function text(id, s, cls) {
    const el = $(id);
    if (!el) return;
    el.textContent = s;
    if (cls !== undefined) el.className = cls;
  }
  function clock(ms) {
    const s = Math.max(0, ms) / 1000;
    const m = Math.floor(s / 60);
    return m + ":" + (s - 60 * m).toFixed(1).padStart(4, "0");
  }

  // --- the connection ---------------------------------------------------------------------------
  let ws = null;
  function connect() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    ws = new WebSocket(proto + "//" + location.host + "/ws");
    ws.onopen = () => text("conn", "connected", "good");
    ws.onclose = () => { text("conn", "not connected: retrying", "bad"); setTimeout(connect, 1000); };
    ws.onmessage = (ev) => {
      let msg;
      try { msg = JSON.parse(ev.data); } catch (e) { return; }
      const now = performance.now();
      if (msg.kind === "hello") onHello(msg);
      else if (msg.kind === "state") { D.received.state++; arrivals.state.push(now); onState(msg); }
      else if (msg.kind === "frame") { D.received.frame++; arrivals.frame.push(now); onFrame(msg); }
      else if (msg.kind === "jetson") { D.received.jetson++; onJetson(msg); }
      else if (msg.kind === "cursor") onCursor(msg);
    };
  }
  function send(obj) { if (ws && ws.readyState === 1) ws.send(JSON.stringify(obj)); }

  function onHello(msg) {
    D.hello = msg;
    text("mode", msg.mode === "replay" ? "replay of " + msg.title : "live: " + msg.title);
    document.title = "Pete: " + msg.title;
    if (msg.mode === "replay") {
      $("replay").classList.remove("hidden");
      const s = $("slider");
      s.min = msg.start_t; s.max = msg.end_t; s.value = msg.start_t;
    }
  }

  // --- replay controls (this page's cursor only) ------------------------------------------------
  $("slider").addEventListener("input", (e) => send({ seek: Number(e.target.value) }));
  $("play").addEventListener("click", () => send({ play: !(D.cursor && D.cursor.playing) }));
  $("speed").addEventListener("change", (e) => send({ speed: Number(e.target.value) }));
  function onCursor(msg) {
    D.cursor = msg;
    const start = D.hello ? D.hello.start_t : 0;
    text("cursor", (msg.t - start).toFixed(1) + " s");
    $("play").textContent = msg.playing ? "pause" : "play";
    if (document.activeElement !== $("slider")) $("slider").value = msg.t;
  }

  // --- state ------------------------------------------------------------------------------------
  function onState(s) {
    D.prev = D.state;
    D.state = s;
    const p = D.prev;
    if (p && s.t > p.t && s.link && p.link) {
      const dt = s.t - p.t;
      D.linkRates.up_hz = (s.link.received - p.link.received) / dt;
      D.linkRates.down_hz = (s.link.commands - p.link.commands) / dt;
    } else if (p && s.t < p.t) { D.trail = []; D.commands = []; }
    if (s.command) {
      D.commands.push([s.t, s.command.linear, s.command.angular]);
      while (D.commands.length && s.t - D.commands[0][0] > 10) D.commands.shift();
    }
    if (s.pose && s.pose.fix !== "lost") {
      const last = D.trail[D.trail.length - 1];
      if (!last || Math.hypot(last[0] - s.pose.x, last[1] - s.pose.y) > 0.02) D.trail.push([s.pose.x, s.pose.y]);
      if (D.trail.length > 600) D.trail.shift();
    }
    drawMatch(s);
    drawLink(s);
    drawField(s);
  }

  function drawMatch(s) {
    const m = s.match;
    if (m) {
      // A VEX AI match: its period and its 120-s clock; otherwise the Brain's phase clock.
      const inMatch = m.period && m.period !== "before";
      text("match-clock", inMatch ? m.period + " " + clock(m.match_ms) + " (" + m.phase + ")"
        : m.phase + " " + clock(m.phase_ms));
      $("match-clock").dataset.phaseMs = m.phase_ms;
      text("phase", m.phase + " (Brain time " + (m.time_ms / 1000).toFixed(1) + " s, State " + m.seq + ")");
      text("alliance", m.alliance, m.alliance === "unknown" ? "bad" : "");
      text("driver", m.driver, m.driver === "jetson" ? "good" : (m.driver === "nobody" ? "warn" : ""));
      text("held", "rings " + (m.rings_held === 255 ? "no counter" : m.rings_held) +
        ", clamp " + (m.clamp || "?") + " (" + (m.goal_clamped === 255 ? "no sensor" : (m.goal_clamped ? "holds a goal" : "no goal")) + ")" +
        ", lift " + (m.lift || "?"));
      text("faults", m.faults.length ? m.faults.join(", ") : "none", m.faults.length ? "warn" : "good");
    } else {
      text("match-clock", "no State yet");
    }
    const c = s.command;
    if (c) {
      text("command", "#" + c.seq + " " + fmt(c.linear, 2) + " m/s " + fmt(c.angular, 2) +
        " rad/s" + (c.intake ? " intake" : "") +
        (c.clamp && c.clamp !== "leave" ? " clamp " + c.clamp : "") +
        (c.lift && c.lift !== "leave" ? " lift " + c.lift : ""));
      const drives = c.reason === "policy" || c.reason === "scripted";
      text("reason", drives ? "driving (" + c.reason + "), perception " + c.perception +
        ", " + c.rings + " rings" : "stop: " + c.reason, drives ? "good" : "warn");
    }
    if (s.speeds) text("speeds", "left " + fmt(s.speeds.left, 2) + " right " + fmt(s.speeds.right, 2) + " m/s");
    const ol = $("brain-lines");
    const lines = s.brain_lines || [];
    const lastShown = ol.dataset.last ? Number(ol.dataset.last) : -1;
    if (!lines.length || lines[lines.length - 1][3] !== lastShown) {
      ol.textContent = "";
      for (const [t, level, line] of lines.slice().reverse()) {
        const li = document.createElement("li");
        li.textContent = t.toFixed(1) + " " + level + ": " + line;
        ol.appendChild(li);
      }
      ol.dataset.last = lines.length ? lines[lines.length - 1][3] : -1;
    }
    drawCommands();
  }

  function drawCommands() {
    const cv = $("commands"), g = cv.getContext("2d");
    g.clearRect(0, 0, cv.width, cv.height);
    g.fillStyle = "#111"; g.fillRect(0, 0, cv.width, cv.height);
    const h = cv.height, mid = h / 2;
    g.strokeStyle = "#444"; g.beginPath(); g.moveTo(0, mid); g.lineTo(cv.width, mid); g.stroke();
    if (D.commands.length < 2) return;
    const t1 = D.commands[D.commands.length - 1][0], t0 = t1 - 10;
    const x = (t) => (t - t0) / 10 * cv.width;
    const series = [[1, "#6d6", 1.5, "linear m/s"], [2, "#3df", 5, "angular rad/s"]];
    series.forEach(([k, colour, full, label], i) => {
      g.strokeStyle = colour; g.beginPath();
      D.commands.forEach((c, j) => {
        const y = mid - (c[k] / full) * (mid - 4);
        if (j === 0) g.moveTo(x(c[0]), y); else g.lineTo(x(c[0]), y);
      });
      g.stroke();
      g.fillStyle = colour; g.fillText(label, 4 + 90 * i, 12);
    });
  }

  function drawLink(s) {
    const l = s.link;
    if (!l) return;
    const cls = l.up ? "good" : (l.state === "mismatch" ? "bad" : "warn");
    text("link-state", l.state + (l.connected ? "" : " (no port)"), cls);
    text("link-port", l.port);
    text("fingerprints", "ours " + l.ours + ", Brain's " + (l.brain || "-") +
      (l.brain && l.brain !== l.ours ? "  MISMATCH" : ""), l.brain && l.brain !== l.ours ? "bad" : "");
    text("rate-up", (D.linkRates.up_hz === null ? "-" : D.linkRates.up_hz.toFixed(1)) + " msg/s, " +
      l.rx_bytes + " bytes");
    text("rate-down", (D.linkRates.down_hz === null ? "-" : D.linkRates.down_hz.toFixed(1)) +
      " Commands/s, " + l.tx_bytes + " bytes");
    text("link-states", String(l.states));
    text("link-commands", String(l.commands));
    text("link-received", l.received + " / " + l.lost);
    const errs = Object.entries(l.errors || {});
    text("link-errors", errs.length ? errs.map(([k, v]) => k + "=" + v).join(" ") : "none",
      errs.length ? "warn" : "good");
    $("link-errors").dataset.total = errs.reduce((a, [, v]) => a + v, 0);
    text("link-connects", l.connects + " connects, " + l.disconnects + " disconnects");
    const lat = l.latency;
    text("latency", lat.n ? "p50 " + fmt(lat.p50_ms, 3) + " ms, p99 " + fmt(lat.p99_ms, 3) +
      " ms, max " + fmt(lat.max_ms, 3) + " ms (last " + lat.n + ")" : "-");
    drawHistogram(lat);
    drawPartner(s.partner);
    const p = s.perception;
    if (p) {
      text("perception", "#" + p.id + ": " + p.rings + " rings of " + p.detections + " detections, " +
        fmt(p.age_ms, 0) + " ms old, " + fmt(p.process_ms, 1) + " ms" + (p.error ? ", ERROR " + p.error : ""),
        p.error ? "bad" : "");
    } else text("perception", s.has_camera ? "no result yet" : "no camera");
  }

  // The alliance partner over VEXlink (jetson/dashboard/snapshot.py partner_view): the link as
  // the Brain sees it, and the partner's newest report.
  function drawPartner(pv) {
    const cell = $("partner-link");
    if (!pv) { text("partner-link", "no report from the Brain"); cell.dataset.link = ""; text("partner", "-"); return; }
    const up = pv.link === "up";
    text("partner-link", (pv.link || "no status yet") + (pv.link && pv.link !== "absent" ? ", " +
      pv.received + " in / " + pv.sent + " out, " + pv.lost + " lost, " + pv.errors + " corrupt" +
      (pv.age_ms === null ? "" : ", newest " + pv.age_ms + " ms ago") : (pv.link ? " (no radio)" : "")) +
      (up ? "" : "  playing alone"), up ? "good" : (pv.link === "lost" ? "bad" : "warn"));
    cell.dataset.link = pv.link || "";
    const r = pv.report;
    if (!r) { text("partner", "no report yet"); return; }
    text("partner", (r.pose ? "(" + fmt(r.pose[0], 2) + ", " + fmt(r.pose[1], 2) + ") " + fmt(r.pose[2], 0) + " deg" : "no pose") +
      ", " + (r.rings === null ? "?" : r.rings) + " rings" + (r.holding ? ", holding a goal" : "") +
      (r.on_platform ? ", on the platform" : "") + (r.driving ? "" : ", not driven by its Jetson") +
      ", claims " + r.target + (r.target_xy ? " (" + fmt(r.target_xy[0], 2) + ", " + fmt(r.target_xy[1], 2) + ")" : "") +
      (r.delay_ms === null ? "" : ", " + r.delay_ms + " ms old"));
  }

  function drawHistogram(lat) {
    const cv = $("latency-hist"), g = cv.getContext("2d");
    g.fillStyle = "#111"; g.fillRect(0, 0, cv.width, cv.height);
    const n = lat.hist.length, w = cv.width / n, top = Math.max(1, ...lat.hist);
    for (let i = 0; i < n; i++) {
      const h = (cv.height - 24) * lat.hist[i] / top;
      g.fillStyle = lat.edges_ms[i] >= 5 ? "#f66" : "#3df";
      g.fillRect(i * w + 2, cv.height - 14 - h, w - 4, h);
      g.fillStyle = "#9ab";
      const label = i + 1 < n ? "<" + lat.edges_ms[i + 1] : ">" + lat.edges_ms[i];
      g.fillText(label, i * w + 4, cv.height - 2);
    }
    g.fillText("ms", cv.width - 16, 10);
  }

  // --- the field --------------------------------------------------------------------------------
  function fieldTransform(cv) {
    const half = D.hello ? D.hello.field_half_m : 1.8288;
    const scale = (Math.min(cv.width, cv.height) - 20) / (2 * half);
    const cx = cv.width / 2, cy = cv.height / 2;
    return {
      half, scale,
      px: (x, y) => [cx + x * scale, cy - y * scale],
      inv: (u, v) => [(u - cx) / scale, (cy - v) / scale],
    };
  }

  function drawField(s) {
    const cv = $("field"), g = cv.getContext("2d");
    const T = fieldTransform(cv);
    g.fillStyle = "#3a3f46"; g.fillRect(0, 0, cv.width, cv.height);
    const [x0, y0] = T.px(-T.half, T.half);
    g.fillStyle = "#565d66"; g.fillRect(x0, y0, 2 * T.half * T.scale, 2 * T.half * T.scale);
    g.strokeStyle = "#777"; g.lineWidth = 1;
    for (let k = -2; k <= 2; k++) {  // tiles: 2 ft
      const a = T.px(k * T.half / 3, -T.half), b = T.px(k * T.half / 3, T.half);
      g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(b[0], b[1]); g.stroke();
      const c = T.px(-T.half, k * T.half / 3), d = T.px(T.half, k * T.half / 3);
      g.beginPath(); g.moveTo(c[0], c[1]); g.lineTo(d[0], d[1]); g.stroke();
    }
    const f = s.field || {};
    const dot = (p, r, fill, stroke) => {
      const [u, v] = T.px(p[0], p[1]);
      g.beginPath(); g.arc(u, v, r, 0, 2 * Math.PI);
      if (fill) { g.fillStyle = fill; g.fill(); }
      if (stroke) { g.strokeStyle = stroke; g.lineWidth = 2; g.stroke(); }
    };
    // the trail driven
    if (D.trail.length > 1) {
      g.strokeStyle = "rgba(255,255,255,0.35)"; g.lineWidth = 1; g.beginPath();
      D.trail.forEach((p, j) => { const [u, v] = T.px(p[0], p[1]); if (j) g.lineTo(u, v); else g.moveTo(u, v); });
      g.stroke();
    }
    // a goal's base: a hexagon of radius r pixels around the point p (field frame)
    const hexagon = (p, r) => {
      const [u, v] = T.px(p[0], p[1]);
      g.beginPath();
      for (let k = 0; k < 6; k++) {
        const a = Math.PI / 3 * k;
        if (k) g.lineTo(u + r * Math.cos(a), v + r * Math.sin(a));
        else g.moveTo(u + r * Math.cos(a), v + r * Math.sin(a));
      }
      g.closePath();
    };
    (f.goals || []).forEach((p) => {
      hexagon(p, 12); g.strokeStyle = "#fd3"; g.lineWidth = 2; g.stroke();
    });
    // the goals the camera saw (live and in a replay; jetson/dashboard/snapshot.py goals_field): [x, y, colour code],
    // filled in the base's colour (jetson/autonomy/goal_colours.py: yellow, red, blue)
    (f.goals_seen || []).forEach((p) => {
      hexagon(p, 8); g.fillStyle = ["#fd3", "#e33", "#38f"][p[2]] || "#fff"; g.fill();
    });
    // the robots the camera saw by their licence plates (snapshot.py robots_field): [x, y, alliance code],
    // a robot-sized square (0.38 m, its heading unknown) in the alliance's colour (1 red, 2 blue)
    (f.robots_seen || []).forEach((p) => {
      const [u, v] = T.px(p[0], p[1]), side = 0.38 * T.scale;
      const colour = ({ 1: "#e33", 2: "#38f" })[p[2]] || "#fff";
      g.globalAlpha = 0.45; g.fillStyle = colour; g.fillRect(u - side / 2, v - side / 2, side, side);
      g.globalAlpha = 1; g.strokeStyle = colour; g.lineWidth = 2; g.strokeRect(u - side / 2, v - side / 2, side, side);
    });
    (f.forgotten || []).forEach((p) => {
      const [u, v] = T.px(p[0], p[1]);
      const alpha = Math.max(0.15, 1 - p[2] / 5);
      g.strokeStyle = "rgba(170,170,170," + alpha + ")"; g.lineWidth = 2;
      g.beginPath(); g.moveTo(u - 5, v - 5); g.lineTo(u + 5, v + 5); g.moveTo(u + 5, v - 5); g.lineTo(u - 5, v + 5); g.stroke();
    });
    (f.remembered || []).forEach((p) => dot(p, 5, null, "#c8c"));
    (f.seen || []).forEach((p) => dot(p, 6, "#f0f", null));
    if (f.path && f.path.length > 1) {
      g.strokeStyle = "#3df"; g.lineWidth = 2; g.setLineDash([6, 4]); g.beginPath();
      f.path.forEach((p, j) => { const [u, v] = T.px(p[0], p[1]); if (j) g.lineTo(u, v); else g.moveTo(u, v); });
      g.stroke(); g.setLineDash([]);
    }
    (f.route || []).forEach((p, j) => { const [u, v] = T.px(p[0], p[1]); g.fillStyle = "#3df"; g.fillText(String(j + 1), u + 7, v - 7); });
    if (f.target) star(g, T.px(f.target[0], f.target[1]), 9, "#3df");
    // what our robot claims for its partner (VEXlink): a hollow star in its colour
    D.drawn.claim = null;
    if (f.claim && f.claim.xy) {
      star(g, T.px(f.claim.xy[0], f.claim.xy[1]), 11, null);
      g.strokeStyle = "#3df"; g.lineWidth = 2; g.stroke();
      D.drawn.claim = f.claim;
    }
    D.drawn.rings = { seen: (f.seen || []).length, remembered: (f.remembered || []).length, forgotten: (f.forgotten || []).length };
    D.drawn.goals = (f.goals || []).length;
    D.drawn.robots_seen = (f.robots_seen || []).length;
    text("robot-counts", D.drawn.robots_seen + " seen");
    text("ring-counts", D.drawn.rings.seen + " seen, " + D.drawn.rings.remembered + " remembered, " +
      D.drawn.rings.forgotten + " forgotten" + (f.memory ? "" : " (this policy has no ring memory)"));
    $("ring-counts").dataset.seen = D.drawn.rings.seen;
    $("ring-counts").dataset.remembered = D.drawn.rings.remembered;
    text("goal-counts", (f.goals_seen ? f.goals_seen.length + " seen, " : "") + D.drawn.goals + " remembered" + (f.holding ? ", holding one" : "") +
      (f.goal_memory ? "" : " (no goal memory)"));
    const claim = f.claim ? "; claims " + f.claim.target + " (" + fmt(f.claim.xy[0], 2) + ", " + fmt(f.claim.xy[1], 2) + ")" : "";
    text("skill", (f.skill ? f.skill + (f.target ? " -> (" + fmt(f.target[0], 2) + ", " + fmt(f.target[1], 2) + ")" : "") : "-") + claim);
    // the partner (its newest VEXlink report): a hollow square, its claimed target a hollow star
    D.drawn.partner = null;
    const pr = s.partner && s.partner.report;
    if (pr && pr.pose) {
      const [u, v] = T.px(pr.pose[0], pr.pose[1]);
      const side = 0.38 * T.scale;
      g.save(); g.translate(u, v); g.rotate(pr.pose[2] * Math.PI / 180);
      g.strokeStyle = s.match && s.match.alliance === "blue" ? "#8af" : "#f88";
      g.lineWidth = 3; g.setLineDash(s.partner.link === "up" ? [] : [4, 4]);
      g.strokeRect(-side / 2, -side / 2, side, side);
      g.beginPath(); g.moveTo(0, 0); g.lineTo(0, -side * 0.7); g.stroke(); g.setLineDash([]);
      g.restore();
      D.drawn.partner = { x: pr.pose[0], y: pr.pose[1], heading: pr.pose[2] };
    }
    if (pr && pr.target_xy) {  // its claim, with or without its pose
      const c = T.px(pr.target_xy[0], pr.target_xy[1]);
      star(g, c, 9, null); g.strokeStyle = "#fa3"; g.lineWidth = 2; g.stroke();
    }
    // the robot, last so it is on top
    const pose = s.pose;
    if (pose) {
      const [u, v] = T.px(pose.x, pose.y);
      const h = pose.heading * Math.PI / 180;  // clockwise from +y
      const side = 0.38 * T.scale;
      g.save(); g.translate(u, v); g.rotate(h);
      g.fillStyle = pose.fix !== "lost" ? (s.match && s.match.alliance === "blue" ? "#48f" : "#e44") : "#888";
      g.fillRect(-side / 2, -side / 2, side, side);
      g.strokeStyle = "#fff"; g.lineWidth = 3; g.beginPath(); g.moveTo(0, 0); g.lineTo(0, -side * 0.7); g.stroke();
      g.restore();
      const back = T.inv(u, v);
      D.drawn.robot = { x: back[0], y: back[1], heading: pose.heading };
      // The pose is the Brain's filter's (GPS, odometry, IMU): what it rests on and its spread.
      text("pose-info", "x " + fmt(pose.x, 3) + " y " + fmt(pose.y, 3) + " m, heading " + fmt(pose.heading, 1) +
        " deg; pose " + pose.fix + " +-" + fmt(pose.std * 100, 1) + " cm, " + fmt(pose.heading_std, 1) +
        " deg; GPS " + pose.gps_status + " (" + fmt(pose.gps_error * 100, 1) + " cm)",
        pose.fix === "lost" ? "bad" : (pose.fix === "gps" ? "" : "warn"));
    }
  }

  function star(g, c, r, colour) {
    g.beginPath();
    for (let k = 0; k < 10; k++) {
      const a = -Math.PI / 2 + Math.PI / 5 * k, rr = k % 2 ? r / 2.5 : r;
      const q = [c[0] + rr * Math.cos(a), c[1] + rr * Math.sin(a)];
      if (k) g.lineTo(q[0], q[1]); else g.moveTo(q[0], q[1]);
    }
    g.closePath();
    if (colour) { g.fillStyle = colour; g.fill(); }
  }

  // --- the camera -------------------------------------------------------------------------------
  function onFrame(fr) {
    D.frame = { id: fr.id, stamp: fr.stamp, boxes: fr.boxes, size: fr.size };
    const img = new Image();
    img.onload = () => {
      const cv = $("camera"), g = cv.getContext("2d");
      const w = 640, h = Math.round(640 * fr.size[1] / fr.size[0]);
      if (cv.width !== w || cv.height !== h) { cv.width = w; cv.height = h; }
      g.drawImage(img, 0, 0, w, h);
      const sx = w / fr.size[0], sy = h / fr.size[1];
      g.lineWidth = 2; g.font = "13px sans-serif";
      for (const [bx0, by0, bx1, by1, score, dist] of fr.boxes) {
        g.strokeStyle = dist === null ? "#fc6" : "#0f0";
        g.strokeRect(bx0 * sx, by0 * sy, (bx1 - bx0) * sx, (by1 - by0) * sy);
        g.fillStyle = g.strokeStyle;
        g.fillText((dist === null ? "?" : dist.toFixed(2) + " m") + " " + Math.round(score * 100) + "%", bx0 * sx, Math.max(12, by0 * sy - 3));
      }
      D.cameraDrawn++;
      text("camera-info", "frame " + fr.id + ", " + fr.boxes.length + " detections");
    };
    img.src = "data:image/jpeg;base64," + fr.jpeg;
    if (fr.depth) {
      const dimg = new Image();
      dimg.onload = () => {
        const cv = $("depth"), g = cv.getContext("2d");
        const w = 320, h = Math.round(320 * fr.size[1] / fr.size[0]);
        if (cv.width !== w || cv.height !== h) { cv.width = w; cv.height = h; }
        g.drawImage(dimg, 0, 0, w, h);
      };
      dimg.src = "data:image/jpeg;base64," + fr.depth;
    }
  }

  // How much the camera picture varies (0: blank); for tests and for people alike.
  D.cameraSpread = function () {
    const cv = $("camera"), g = cv.getContext("2d");
    const px = g.getImageData(0, 0, cv.width, cv.height).data;
    let lo = 255, hi = 0;
    for (let i = 0; i < px.length; i += 4 * 7) {
      const y = (px[i] + px[i + 1] + px[i + 2]) / 3;
      if (y < lo) lo = y;
      if (y > hi) hi = y;
    }
    return hi - lo;
  };

  // --- the Jetson -------------------------------------------------------------------------------
  function onJetson(j) {
    D.jetson = j;
    text("cpu", (j.cpu_pct === null ? "-" : j.cpu_pct + " % of " + j.cpus + " cores") +
      ", pete-jetson " + fmt(j.process_cpu_pct, 1) + " % (dashboard " + fmt(j.dashboard_cpu_pct, 2) + " %)" +
      (j.load === null ? "" : ", load " + j.load));
    text("memory", (j.mem_used_pct === null ? "-" : j.mem_used_pct + " % of " + j.mem_total_gb + " GB") +
      ", pete-jetson " + fmt(j.rss_mb, 0) + " MB");
    const temps = Object.entries(j.temps_c || {});
    text("temperature", temps.length ? temps.map(([k, v]) => k + " " + v + " C").join(", ") : "not readable here",
      j.temp_max_c !== null && j.temp_max_c > 85 ? "bad" : "");
    text("disk", j.disk ? j.disk.free_gb + " GB free of " + j.disk.total_gb + " GB (" + j.disk.path + ")" : "not recording");
  }

  setInterval(() => {
    const now = performance.now();
    for (const k of ["state", "frame"]) {
      const a = arrivals[k];
      while (a.length && now - a[0] > 2000) a.shift();
    }
    D.rates.state_hz = arrivals.state.length / 2;
    D.rates.frame_hz = arrivals.frame.length / 2;
    text("page-rates", D.rates.state_hz.toFixed(1) + " updates/s, " + D.rates.frame_hz.toFixed(1) + " frames/s");
  }, 500);

  connect();
})();
