//! `pqm view` as an HTTP server: started as a user would (`--port 0
//! --json`), spoken to over raw TCP, so every header and status line the
//! browser sees is checked: Range forms (valid, suffix, open, clipped,
//! unsatisfiable, multi-range, ignored), HEAD, 404/405, the embedded page,
//! the throttle, and refusing files that are not `.pqm`.
//!
//! The page itself is exercised in a real browser by
//! `web/browser-test/view.test.mjs`.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

fn pqm_bin() -> &'static str {
    env!("CARGO_BIN_EXE_pqm")
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/generated")
        .join(name)
}

/// A small real `.pqm` (the generated torus), encoded into `dir`.
fn encode_torus(dir: &Path) -> (PathBuf, Vec<u8>) {
    let out = dir.join("torus.pqm");
    let st = Command::new(pqm_bin())
        .args(["-q", "encode"])
        .arg(fixture("torus.obj"))
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success(), "pqm encode failed");
    let bytes = std::fs::read(&out).unwrap();
    (out, bytes)
}

/// A running `pqm view`; killed on drop.
struct Server {
    child: Child,
    addr: String,
    url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start(file: &Path, extra: &[&str]) -> Server {
    let mut child = Command::new(pqm_bin())
        .args(["--json", "view"])
        .arg(file)
        .args(["--port", "0"])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let v: serde_json::Value = serde_json::from_str(line.trim())
        .unwrap_or_else(|e| panic!("first stdout line is not JSON ({e}): {line:?}"));
    let url = v["url"].as_str().expect("url").to_string();
    let addr = url
        .strip_prefix("http://")
        .and_then(|s| s.strip_suffix('/'))
        .expect("http://HOST:PORT/")
        .to_string();
    Server { child, addr, url }
}

/// A response: status code, headers (lower-case names), body.
struct Response {
    status: u16,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Response {
    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }
}

/// Sends `method path` with extra header lines, reads the response to EOF
/// (the server closes every connection).
fn request(server: &Server, method: &str, path: &str, headers: &[&str]) -> Response {
    let mut s = TcpStream::connect(&server.addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    let mut req = format!("{method} {path} HTTP/1.1\r\nHost: {}\r\n", server.addr);
    for h in headers {
        req.push_str(h);
        req.push_str("\r\n");
    }
    req.push_str("\r\n");
    s.write_all(req.as_bytes()).unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("end of head");
    let head = String::from_utf8(raw[..split].to_vec()).unwrap();
    let body = raw[split + 4..].to_vec();
    let mut lines = head.split("\r\n");
    let status_line = lines.next().unwrap();
    assert!(status_line.starts_with("HTTP/1.1 "), "{status_line}");
    let status = status_line[9..12].parse().unwrap();
    let headers = lines
        .map(|l| {
            let (k, v) = l.split_once(':').expect("header line");
            (k.trim().to_ascii_lowercase(), v.trim().to_string())
        })
        .collect();
    let r = Response {
        status,
        headers,
        body,
    };
    if method != "HEAD" {
        let cl: usize = r.header("content-length").unwrap().parse().unwrap();
        assert_eq!(cl, r.body.len(), "Content-Length of {path}");
    }
    r
}

#[test]
fn serves_page_script_and_file_on_localhost() {
    let dir = TempDir::new().unwrap();
    let (file, bytes) = encode_torus(dir.path());
    let srv = start(&file, &[]);
    assert!(srv.url.starts_with("http://127.0.0.1:"), "{}", srv.url);

    let page = request(&srv, "GET", "/", &[]);
    assert_eq!(page.status, 200);
    assert!(page
        .header("content-type")
        .unwrap()
        .starts_with("text/html"));
    let html = String::from_utf8(page.body).unwrap();
    assert!(html.contains("<script src=\"viewer.js\">"), "{html}");
    assert!(html.contains("torus.pqm"), "the page names the file");
    assert!(!html.contains("__PQM_FILE_NAME__"));
    for id in ["faces", "bytes", "error", "level-slider", "wireframe"] {
        assert!(html.contains(&format!("id=\"{id}\"")), "#{id} missing");
    }

    let js = request(&srv, "GET", "/viewer.js", &[]);
    assert_eq!(js.status, 200);
    assert!(js
        .header("content-type")
        .unwrap()
        .starts_with("text/javascript"));
    assert!(js.body.len() > 100_000, "the bundle includes three.js");

    let full = request(&srv, "GET", "/mesh.pqm", &[]);
    assert_eq!(full.status, 200);
    assert_eq!(full.header("accept-ranges"), Some("bytes"));
    assert_eq!(full.body, bytes);

    let head = request(&srv, "HEAD", "/mesh.pqm", &[]);
    assert_eq!(head.status, 200);
    assert!(head.body.is_empty(), "HEAD has no body");
    assert_eq!(
        head.header("content-length"),
        Some(&*bytes.len().to_string())
    );
    assert_eq!(head.header("accept-ranges"), Some("bytes"));

    assert_eq!(request(&srv, "GET", "/nothing", &[]).status, 404);
    assert_eq!(request(&srv, "GET", "/compare.glb", &[]).status, 404);
    let post = request(&srv, "POST", "/mesh.pqm", &[]);
    assert_eq!(post.status, 405);
    assert_eq!(post.header("allow"), Some("GET, HEAD"));
}

#[test]
fn range_requests() {
    let dir = TempDir::new().unwrap();
    let (file, bytes) = encode_torus(dir.path());
    let len = bytes.len();
    let srv = start(&file, &[]);
    let get = |range: &str| request(&srv, "GET", "/mesh.pqm", &[&format!("Range: {range}")]);

    // (header, expected first byte, expected last byte)
    let cases = [
        ("bytes=0-99".to_string(), 0, 99),
        ("bytes=100-100".to_string(), 100, 100),
        (format!("bytes=50-{}", len + 1000), 50, len - 1), // end clipped
        ("bytes=-10".to_string(), len - 10, len - 1),      // suffix
        (format!("bytes=-{}", len + 5), 0, len - 1),       // suffix longer than the file
        (format!("bytes={}-", len - 7), len - 7, len - 1), // open
    ];
    for (h, a, b) in cases {
        let r = get(&h);
        assert_eq!(r.status, 206, "{h}");
        assert_eq!(
            r.header("content-range"),
            Some(&*format!("bytes {a}-{b}/{len}")),
            "{h}"
        );
        assert_eq!(r.body, &bytes[a..=b], "{h}");
    }

    for h in [
        format!("bytes={len}-"),
        format!("bytes={}-{}", len + 1, len + 9),
        "bytes=-0".into(),
    ] {
        let r = get(&h);
        assert_eq!(r.status, 416, "{h}");
        assert_eq!(
            r.header("content-range"),
            Some(&*format!("bytes */{len}")),
            "{h}"
        );
        assert!(r.body.is_empty());
    }

    // Several ranges, another unit, garbage, a reversed range: the whole file
    // with 200 (documented in `parse_range`).
    for h in ["bytes=0-1,5-9", "items=0-9", "bytes=x-y", "bytes=9-3"] {
        let r = get(h);
        assert_eq!(r.status, 200, "{h}");
        assert_eq!(r.header("content-range"), None, "{h}");
        assert_eq!(r.body, bytes, "{h}");
    }

    // HEAD with a range: the 206 head without the body.
    let r = request(&srv, "HEAD", "/mesh.pqm", &["Range: bytes=0-9"]);
    assert_eq!(r.status, 206);
    assert_eq!(r.header("content-length"), Some("10"));
    assert!(r.body.is_empty());

    // Range does not apply to the page.
    let r = request(&srv, "GET", "/", &["Range: bytes=0-9"]);
    assert_eq!(r.status, 200);
}

#[test]
fn throttle_paces_the_mesh_but_not_the_page() {
    let dir = TempDir::new().unwrap();
    let (file, bytes) = encode_torus(dir.path());
    let srv = start(&file, &["--throttle", "4"]);
    let t = Instant::now();
    let r = request(&srv, "GET", "/mesh.pqm", &[]);
    let took = t.elapsed().as_secs_f64();
    assert_eq!(r.body, bytes, "throttling must not change the bytes");
    // A lower bound only (a busy machine can be slower, never faster).
    let min = 0.9 * bytes.len() as f64 / 4096.0;
    assert!(
        took >= min,
        "{} bytes at 4 KiB/s took {took:.2} s < {min:.2} s",
        bytes.len()
    );
    // The page is not throttled: 700 kB of script at 4 KiB/s would take minutes.
    let t = Instant::now();
    assert_eq!(request(&srv, "GET", "/viewer.js", &[]).status, 200);
    assert!(t.elapsed() < Duration::from_secs(20));
}

#[test]
fn compare_file_is_served_when_given() {
    let dir = TempDir::new().unwrap();
    let (file, _) = encode_torus(dir.path());
    let glb = dir.path().join("x.glb");
    std::fs::write(&glb, b"glTF-not-really").unwrap();
    let srv = start(&file, &["--compare", glb.to_str().unwrap()]);
    let r = request(&srv, "GET", "/compare.glb", &["Range: bytes=0-3"]);
    assert_eq!(r.status, 206);
    assert_eq!(r.body, b"glTF");
    assert_eq!(r.header("content-type"), Some("model/gltf-binary"));
}

#[test]
fn refuses_what_is_not_a_pqm_file() {
    let dir = TempDir::new().unwrap();
    let obj = fixture("cube.obj");
    let out = Command::new(pqm_bin())
        .arg("view")
        .arg(&obj)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cube.obj") && err.contains(".pqm"), "{err}");
    assert!(out.stdout.is_empty(), "no URL printed for a refused file");

    // a damaged .pqm: the decoder's error, naming the file
    let (file, mut bytes) = encode_torus(dir.path());
    let n = bytes.len();
    bytes[n / 2] ^= 0x55;
    let bad = dir.path().join("bad.pqm");
    std::fs::write(&bad, &bytes).unwrap();
    let out = Command::new(pqm_bin())
        .arg("view")
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.pqm"), "{err}");
    drop(file);

    let missing = dir.path().join("missing.pqm");
    let out = Command::new(pqm_bin())
        .arg("view")
        .arg(&missing)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.pqm"));

    // bad throttle: usage error
    let out = Command::new(pqm_bin())
        .args(["view", "x.pqm", "--throttle", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn help_has_examples_and_documents_the_throttle() {
    let out = Command::new(pqm_bin())
        .args(["view", "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for want in [
        "Examples:",
        "--port",
        "--throttle",
        "Testing aid",
        "127.0.0.1",
    ] {
        assert!(
            help.contains(want),
            "`pqm view --help` lacks {want:?}:\n{help}"
        );
    }
}

/// Sends raw bytes, returns the status line of the answer.
fn raw_status(server: &Server, raw: &[u8]) -> String {
    let mut s = TcpStream::connect(&server.addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    // The server may answer before it has read everything.
    let _ = s.write_all(raw);
    // End of the request: an incomplete head is then an error, not a wait.
    let _ = s.shutdown(std::net::Shutdown::Write);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out);
    text.lines().next().unwrap_or("").to_string()
}

#[test]
fn malformed_requests_get_400_and_the_server_keeps_serving() {
    let dir = TempDir::new().unwrap();
    let (file, bytes) = encode_torus(dir.path());
    let srv = start(&file, &[]);
    assert!(raw_status(&srv, b"GARBAGE\r\n\r\n").starts_with("HTTP/1.1 400"));
    assert!(raw_status(&srv, b"GET / SPDY/3\r\n\r\n").starts_with("HTTP/1.1 400"));
    let mut long = b"GET / HTTP/1.1\r\nX-Long: ".to_vec();
    long.extend(std::iter::repeat_n(b'a', 20_000));
    long.extend(b"\r\n\r\n");
    assert!(raw_status(&srv, &long).starts_with("HTTP/1.1 400"));
    assert!(raw_status(&srv, b"GET / HTTP/1.1\r\nHost: x\r\n").starts_with("HTTP/1.1 400"));
    // a client that connects and leaves
    drop(TcpStream::connect(&srv.addr).unwrap());
    assert_eq!(request(&srv, "GET", "/mesh.pqm", &[]).body, bytes);
}
