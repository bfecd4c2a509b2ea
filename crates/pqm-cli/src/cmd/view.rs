//! `pqm view`: a local web viewer that streams a `.pqm` file into the page.
//!
//! The server is a small hand-written HTTP/1.1 server on `std::net` (no
//! crate): it serves four fixed resources, so routing, a `Range` parser and a
//! response writer are all it needs, and it stays auditable in one file.
//! (`tiny_http` would work too, but would add a dependency and still need the
//! Range logic below.)
//!
//! * It binds **127.0.0.1 only**: the viewer is a local tool, never a public
//!   server.
//! * It is **offline**: the page (`web/viewer/dist/index.html`) and its
//!   script (`web/viewer/dist/viewer.js`, three.js + OrbitControls +
//!   `pqm-three` + `pqm-decoder` bundled by esbuild) are compiled into the
//!   binary with `include_str!`, so no CDN and no npm are needed at run time
//!   or at `cargo build` time.
//! * The file is read and validated once at start (the whole `.pqm` is
//!   decoded, so a damaged file is refused with the decoder's error naming
//!   the section) and then served from memory: every response sees the same
//!   bytes even if the file changes on disk.
//!
//! Resources:
//!
//! | path | content |
//! |---|---|
//! | `/`, `/index.html` | the viewer page |
//! | `/viewer.js` | the bundled script |
//! | `/mesh.pqm` | the file (Range requests supported) |
//! | `/compare.glb` | with `--compare FILE.glb` only: that file (benchmarks) |
//!
//! HTTP: `GET` and `HEAD` (anything else: 405). One request per connection
//! (`Connection: close`), one thread per connection. `Range` on the mesh
//! files follows RFC 9110 §14: see [`parse_range`] for the accepted forms;
//! the mesh responses carry `Accept-Ranges: bytes`, and every response
//! `Cache-Control: no-cache` (a reload fetches again, since there are no
//! validators, so benchmarks measure the transfer each time; `no-store`
//! would do the same but makes chromium report the streamed fetch as
//! aborted once it completes).
//!
//! `--throttle KIB_PER_S` is a **testing aid** that simulates a slow link:
//! each mesh response (`/mesh.pqm`, `/compare.glb`) is written in small
//! pieces paced to that rate (KiB = 1024 bytes per second, per response).
//! The page and its script are not throttled — they stand for a cached app —
//! so the figures measure the mesh transfer alone.

use crate::ctx::Ctx;
use anyhow::{anyhow, bail, Context};
use pqm_format::{Decoder, Limits};
use serde::Serialize;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The page, compiled in (built by `npm run build:viewer --prefix web`).
const INDEX_HTML: &str = include_str!("../../../../web/viewer/dist/index.html");
/// The bundled viewer script, compiled in.
const VIEWER_JS: &str = include_str!("../../../../web/viewer/dist/viewer.js");

/// Longest request head (request line + headers) accepted, in bytes.
const MAX_HEAD_BYTES: usize = 16 * 1024;
/// Connections served at once; more get `503` (a local viewer needs a few).
const MAX_CONNECTIONS: usize = 64;
/// How long a connection may take to send its request head.
const READ_TIMEOUT: Duration = Duration::from_secs(10);

/// Serve a .pqm file and a web viewer on 127.0.0.1.
///
/// Prints the URL and runs until Ctrl-C. Open the URL in a browser: the
/// mesh refines as it streams, a slider moves between levels (back =
/// coarser), drag to orbit, "level by view" draws the coarsest level whose
/// error spans at most a pixel, and the panel shows faces, bytes received
/// and the current level's geometric error. Add `?view` (or `?view=PIXELS`) to the URL
/// to download by view instead: HTTP Range requests for only the chunks
/// the view's level needs, one more each time zooming in asks for a finer
/// level. Everything is served by this binary (no network access needed).
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:
  pqm view spot.pqm                      serves on a free port, prints the URL
  pqm view spot.pqm --port 8080
  pqm view spot.pqm --port 0 --json      prints {\"url\": ...} as one line
  pqm view spot.pqm --throttle 64        simulate a 64 KiB/s link (testing aid)
  (open URL?view=4 to download only what the view needs at 4 pixels of error)")]
pub struct Args {
    /// The .pqm file to serve.
    pub input: PathBuf,
    /// TCP port on 127.0.0.1; 0 picks a free one.
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Testing aid: send the mesh at most this many KiB (1024 bytes) per
    /// second per response, to simulate a slow link. The page itself is not
    /// throttled.
    #[arg(long, value_name = "KIB_PER_S", value_parser = parse_throttle)]
    pub throttle: Option<f64>,
    /// Testing aid for benchmarks: also serve this file at /compare.glb
    /// (same throttle); the page loads it with three's GLTFLoader when opened
    /// as /?glb.
    #[arg(long, value_name = "FILE.glb")]
    pub compare: Option<PathBuf>,
}

fn parse_throttle(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of KiB per second"))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(format!("the throttle must be > 0 KiB/s, got {s}"));
    }
    Ok(v)
}

/// What a `Range` header asks of a resource of a given length.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RangeRequest {
    /// No usable range: send the whole resource with `200`. Also the answer
    /// to a header that is not a `bytes=` range (RFC 9110 lets a server
    /// ignore such a header) and to several ranges (see [`parse_range`]).
    Full,
    /// Send bytes `start..=end` (inclusive, `end < len`) with `206`.
    Partial { start: u64, end: u64 },
    /// A syntactically valid single range that selects no byte: `416` with
    /// `Content-Range: bytes */len`.
    Unsatisfiable,
}

/// Parses a `Range` header value against a resource of `len` bytes.
///
/// Accepted (RFC 9110 §14.1.2), whitespace around the parts allowed:
/// * `bytes=A-B` → bytes `A..=min(B, len-1)`; unsatisfiable when `A >= len`;
///   malformed (→ [`RangeRequest::Full`]) when `B < A`;
/// * `bytes=A-` → `A..=len-1`; unsatisfiable when `A >= len`;
/// * `bytes=-N` → the last `N` bytes (all of them when `N >= len`);
///   unsatisfiable when `N == 0` or the resource is empty.
///
/// Several ranges (`bytes=0-1,5-6`) are answered with the whole resource
/// (`200`): RFC 9110 lets a server ignore `Range`, and a multipart response
/// would buy nothing for a viewer that only ever asks for one prefix.
/// Anything else (another unit, non-digits, overflow) is ignored the same
/// way.
pub fn parse_range(value: &str, len: u64) -> RangeRequest {
    let Some(spec) = value.trim().strip_prefix("bytes=") else {
        return RangeRequest::Full;
    };
    if spec.contains(',') {
        return RangeRequest::Full;
    }
    let Some((a, b)) = spec.split_once('-') else {
        return RangeRequest::Full;
    };
    let (a, b) = (a.trim(), b.trim());
    let number = |s: &str| -> Option<u64> {
        if s.is_empty() || !s.bytes().all(|c| c.is_ascii_digit()) {
            None
        } else {
            s.parse().ok()
        }
    };
    if a.is_empty() {
        // suffix range: the last N bytes
        let Some(n) = number(b) else {
            return RangeRequest::Full;
        };
        if n == 0 || len == 0 {
            return RangeRequest::Unsatisfiable;
        }
        return RangeRequest::Partial {
            start: len - n.min(len),
            end: len - 1,
        };
    }
    let Some(start) = number(a) else {
        return RangeRequest::Full;
    };
    let end = if b.is_empty() {
        None
    } else {
        match number(b) {
            Some(e) if e >= start => Some(e),
            _ => return RangeRequest::Full,
        }
    };
    if start >= len {
        return RangeRequest::Unsatisfiable;
    }
    RangeRequest::Partial {
        start,
        end: end.map_or(len - 1, |e| e.min(len - 1)),
    }
}

/// One resource the server can send.
struct Resource {
    body: Arc<[u8]>,
    content_type: &'static str,
    /// Mesh files: Range support and the throttle apply.
    is_mesh: bool,
}

/// Everything the connection threads share.
struct Site {
    index: Arc<[u8]>,
    viewer: Arc<[u8]>,
    mesh: Arc<[u8]>,
    compare: Option<Arc<[u8]>>,
    /// Bytes per second for mesh responses, if throttled.
    throttle: Option<f64>,
    active: AtomicUsize,
}

impl Site {
    fn resource(&self, path: &str) -> Option<Resource> {
        let r = |body: &Arc<[u8]>, content_type, is_mesh| Resource {
            body: body.clone(),
            content_type,
            is_mesh,
        };
        // The query string only selects the page's mode; it does not change
        // what is served.
        let path = path.split_once('?').map_or(path, |(p, _)| p);
        match path {
            "/" | "/index.html" => Some(r(&self.index, "text/html; charset=utf-8", false)),
            "/viewer.js" => Some(r(&self.viewer, "text/javascript; charset=utf-8", false)),
            "/mesh.pqm" => Some(r(&self.mesh, "application/octet-stream", true)),
            "/compare.glb" => self
                .compare
                .as_ref()
                .map(|b| r(b, "model/gltf-binary", true)),
            _ => None,
        }
    }
}

#[derive(Serialize)]
struct Started {
    url: String,
}

/// Reads and validates the `.pqm` file: the header must parse and every
/// section present must decode. A file that ends early is served (a client
/// shows what it has) with a warning.
fn load_pqm(path: &Path, ctx: &Ctx) -> anyhow::Result<Vec<u8>> {
    let data = std::fs::read(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let mut dec = Decoder::new(Limits::default());
    dec.push(&data)
        .map_err(|e| anyhow!("{}: not a valid .pqm file: {e}", path.display()))?;
    // The decoder reads the vertex order only when asked (spec §8); ask, so
    // a damaged section is refused here too.
    dec.vertex_order()
        .map_err(|e| anyhow!("{}: not a valid .pqm file: {e}", path.display()))?;
    if dec.header().is_none() {
        bail!(
            "{}: not a .pqm file ({} bytes are not enough for a .pqm header and chunk table)",
            path.display(),
            data.len()
        );
    }
    if !dec.status().finished {
        ctx.warn(format!(
            "{}: the file is incomplete; the viewer shows the levels it holds",
            path.display()
        ));
    }
    Ok(data)
}

/// Escapes text for HTML element content.
fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Runs the command: binds, prints the URL, serves until killed.
pub fn run(args: &Args, ctx: &Ctx) -> anyhow::Result<()> {
    let mesh = load_pqm(&args.input, ctx)?;
    let compare = match &args.compare {
        Some(p) => Some(std::fs::read(p).map_err(|e| anyhow!("{}: {e}", p.display()))?),
        None => None,
    };
    let name = args
        .input
        .file_name()
        .map_or_else(|| "mesh.pqm".into(), |n| n.to_string_lossy().into_owned());
    let index = INDEX_HTML.replace("__PQM_FILE_NAME__", &html_escape(&name));
    let site = Arc::new(Site {
        index: Arc::from(index.into_bytes()),
        viewer: Arc::from(VIEWER_JS.as_bytes()),
        mesh: Arc::from(mesh),
        compare: compare.map(Arc::from),
        throttle: args.throttle.map(|k| k * 1024.0),
        active: AtomicUsize::new(0),
    });
    let listener = TcpListener::bind(SocketAddr::from((Ipv4Addr::LOCALHOST, args.port)))
        .with_context(|| format!("cannot listen on 127.0.0.1:{}", args.port))?;
    let addr = listener.local_addr().context("no local address")?;
    let url = format!("http://{addr}/");
    if ctx.json {
        // One line (not pretty-printed) so a parent process can read it.
        let line = serde_json::to_string(&Started { url: url.clone() })?;
        let mut out = std::io::stdout().lock();
        writeln!(out, "{line}")?;
        out.flush()?;
    } else {
        let mut out = std::io::stdout().lock();
        writeln!(out, "{url}")?;
        out.flush()?;
        ctx.note(format!(
            "serving {} ({} bytes){} — Ctrl-C to stop",
            args.input.display(),
            site.mesh.len(),
            args.throttle
                .map_or(String::new(), |k| format!(", throttled to {k} KiB/s"))
        ));
    }
    for stream in listener.incoming() {
        let stream = match stream {
            Ok(s) => s,
            Err(e) => {
                ctx.verbose(format!("accept failed: {e}"));
                // e.g. out of file descriptors: give the open connections time to finish
                std::thread::sleep(Duration::from_millis(50));
                continue;
            }
        };
        let site = site.clone();
        let verbose = ctx.verbose > 0 && !ctx.quiet;
        std::thread::spawn(move || {
            let n = site.active.fetch_add(1, Ordering::SeqCst);
            let r = if n >= MAX_CONNECTIONS {
                let mut s = stream;
                write_simple(&mut s, 503, "Service Unavailable", "too many connections\n")
            } else {
                serve(stream, &site, verbose)
            };
            site.active.fetch_sub(1, Ordering::SeqCst);
            // A client closing early (a cancelled stream) is normal.
            if let Err(e) = r {
                if verbose {
                    eprintln!("connection: {e}");
                }
            }
        });
    }
    Ok(())
}

/// A parsed request head.
struct Request {
    method: String,
    path: String,
    range: Option<String>,
}

/// Reads the request line and headers. `Ok(None)`: the client sent nothing.
fn read_head(reader: &mut impl BufRead) -> std::io::Result<Option<Result<Request, String>>> {
    let mut total = 0usize;
    let mut lines = Vec::new();
    loop {
        let mut line = Vec::new();
        let n = reader
            .by_ref()
            .take((MAX_HEAD_BYTES - total + 1) as u64)
            .read_until(b'\n', &mut line)?;
        if n == 0 {
            if lines.is_empty() {
                return Ok(None);
            }
            return Ok(Some(Err("request head ended early".into())));
        }
        total += n;
        if total > MAX_HEAD_BYTES {
            return Ok(Some(Err("request head too long".into())));
        }
        let text = String::from_utf8_lossy(&line)
            .trim_end_matches(['\r', '\n'])
            .to_string();
        if text.is_empty() {
            if lines.is_empty() {
                continue; // tolerated blank lines before the request line
            }
            break;
        }
        lines.push(text);
    }
    let mut parts = lines[0].split_ascii_whitespace();
    let (Some(method), Some(path), Some(version)) = (parts.next(), parts.next(), parts.next())
    else {
        return Ok(Some(Err(format!("bad request line `{}`", lines[0]))));
    };
    if !version.starts_with("HTTP/1.") {
        return Ok(Some(Err(format!("unsupported version `{version}`"))));
    }
    let mut range = None;
    for h in &lines[1..] {
        if let Some((k, v)) = h.split_once(':') {
            if k.trim().eq_ignore_ascii_case("range") {
                range = Some(v.trim().to_string());
            }
        }
    }
    Ok(Some(Ok(Request {
        method: method.to_string(),
        path: path.to_string(),
        range,
    })))
}

/// Serves one request on one connection.
fn serve(stream: TcpStream, site: &Site, verbose: bool) -> std::io::Result<()> {
    stream.set_read_timeout(Some(READ_TIMEOUT))?;
    stream.set_nodelay(true)?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut out = stream;
    let req = match read_head(&mut reader)? {
        None => return Ok(()),
        Some(Err(msg)) => {
            write_simple(&mut out, 400, "Bad Request", &format!("{msg}\n"))?;
            return linger_close(out, reader);
        }
        Some(Ok(r)) => r,
    };
    if verbose {
        eprintln!(
            "{} {}{}",
            req.method,
            req.path,
            req.range
                .as_deref()
                .map_or(String::new(), |r| format!(" (Range: {r})"))
        );
    }
    let head_only = match req.method.as_str() {
        "GET" => false,
        "HEAD" => true,
        _ => {
            let body = "only GET and HEAD\n";
            let head = format!(
                "HTTP/1.1 405 Method Not Allowed\r\nAllow: GET, HEAD\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
                body.len()
            );
            // a body may follow that was not read
            out.write_all(head.as_bytes())?;
            return linger_close(out, reader);
        }
    };
    let Some(res) = site.resource(&req.path) else {
        return write_simple(&mut out, 404, "Not Found", "not found\n");
    };
    let len = res.body.len() as u64;
    let range = match (&req.range, res.is_mesh) {
        (Some(v), true) => parse_range(v, len),
        _ => RangeRequest::Full,
    };
    let (status, slice, content_range) = match range {
        RangeRequest::Full => ("200 OK", &res.body[..], None),
        RangeRequest::Partial { start, end } => (
            "206 Partial Content",
            // parse_range guarantees start <= end < len
            &res.body[start as usize..=end as usize],
            Some(format!("bytes {start}-{end}/{len}")),
        ),
        RangeRequest::Unsatisfiable => {
            let head = format!(
                "HTTP/1.1 416 Range Not Satisfiable\r\nContent-Range: bytes */{len}\r\nAccept-Ranges: bytes\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
            );
            return out.write_all(head.as_bytes());
        }
    };
    let mut head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-cache\r\nConnection: close\r\n",
        res.content_type,
        slice.len()
    );
    if res.is_mesh {
        head.push_str("Accept-Ranges: bytes\r\n");
    }
    if let Some(cr) = content_range {
        head.push_str(&format!("Content-Range: {cr}\r\n"));
    }
    head.push_str("\r\n");
    out.write_all(head.as_bytes())?;
    if head_only {
        return out.flush();
    }
    match site.throttle.filter(|_| res.is_mesh) {
        None => out.write_all(slice)?,
        Some(rate) => write_throttled(&mut out, slice, rate)?,
    }
    out.flush()
}

/// Writes `data` paced to `rate` bytes per second: pieces of about 1/20 s of
/// transfer (at least 256 bytes, at most 16 KiB), each sent once the time
/// for the bytes before it has elapsed, so the client sees a steady stream
/// rather than one burst per second.
fn write_throttled(out: &mut impl Write, data: &[u8], rate: f64) -> std::io::Result<()> {
    let piece = ((rate / 20.0) as usize).clamp(256, 16 * 1024);
    let start = Instant::now();
    let mut sent = 0usize;
    for chunk in data.chunks(piece) {
        let due = Duration::from_secs_f64(sent as f64 / rate);
        let elapsed = start.elapsed();
        if due > elapsed {
            std::thread::sleep(due - elapsed);
        }
        out.write_all(chunk)?;
        out.flush()?;
        sent += chunk.len();
    }
    // The last piece also takes its share of time before the response ends.
    let due = Duration::from_secs_f64(sent as f64 / rate);
    let elapsed = start.elapsed();
    if due > elapsed {
        std::thread::sleep(due - elapsed);
    }
    Ok(())
}

/// Closes after an error answer sent before the whole request was read:
/// half-close, then discard what the client still sends (a bounded amount,
/// briefly), so the kernel does not reset the connection — a reset can
/// destroy the answer before the client reads it.
fn linger_close(out: TcpStream, mut reader: impl Read) -> std::io::Result<()> {
    out.shutdown(std::net::Shutdown::Write)?;
    out.set_read_timeout(Some(Duration::from_secs(1)))?;
    let mut sink = [0u8; 4096];
    let mut left = 256 * 1024usize;
    while left > 0 {
        match reader.read(&mut sink) {
            Ok(0) | Err(_) => break,
            Ok(n) => left = left.saturating_sub(n),
        }
    }
    Ok(())
}

/// A short plain-text response.
fn write_simple(out: &mut TcpStream, code: u16, reason: &str, body: &str) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {code} {reason}\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    out.write_all(head.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every start/end/suffix combination on small lengths: a partial range
    /// always lies inside the resource and matches the RFC's definition.
    #[test]
    fn ranges_are_inside_the_resource() {
        for len in 0..6u64 {
            for a in 0..8u64 {
                for b in 0..8u64 {
                    let got = parse_range(&format!("bytes={a}-{b}"), len);
                    let want = if b < a {
                        RangeRequest::Full
                    } else if a >= len {
                        RangeRequest::Unsatisfiable
                    } else {
                        RangeRequest::Partial {
                            start: a,
                            end: b.min(len - 1),
                        }
                    };
                    assert_eq!(got, want, "bytes={a}-{b} of {len}");
                }
                let open = parse_range(&format!("bytes={a}-"), len);
                if a >= len {
                    assert_eq!(open, RangeRequest::Unsatisfiable);
                } else {
                    assert_eq!(
                        open,
                        RangeRequest::Partial {
                            start: a,
                            end: len - 1
                        }
                    );
                }
                let suffix = parse_range(&format!("bytes=-{a}"), len);
                if a == 0 || len == 0 {
                    assert_eq!(suffix, RangeRequest::Unsatisfiable);
                } else {
                    let RangeRequest::Partial { start, end } = suffix else {
                        panic!("bytes=-{a} of {len}: {suffix:?}");
                    };
                    assert_eq!(end, len - 1);
                    assert_eq!(end - start + 1, a.min(len));
                }
            }
        }
    }

    #[test]
    fn other_forms_are_ignored() {
        for v in [
            "items=0-1",
            "bytes=",
            "bytes=-",
            "bytes=a-b",
            "bytes=1-x",
            "bytes=+1-2",
            "bytes=0-1,4-5",
            "bytes=99999999999999999999999-",
        ] {
            assert_eq!(parse_range(v, 10), RangeRequest::Full, "{v}");
        }
        assert_eq!(
            parse_range(" bytes= 2 - 3 ", 10),
            RangeRequest::Partial { start: 2, end: 3 }
        );
    }
}
