//! `raytracer view` without a browser (tests/browser/view_test.py drives the page in
//! headless Chromium): the URL it prints, the page and the camera table it serves, the
//! requests it refuses (other routes, host names and origins), and its errors (a taken
//! port, a bad scene) with exit code 2.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_raytracer");

struct View {
    child: Child,
    host: String,
}

impl View {
    fn start(args: &[&str]) -> View {
        let mut child = Command::new(BIN)
            .args(["view", "--port", "0", "--threads", "1"])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let start = line.find("http://").expect(&line) + 7;
        let end = start + line[start..].find('/').unwrap();
        View {
            child,
            host: line[start..end].to_string(),
        }
    }

    /// The status code and body of a GET of `path` with these extra headers.
    fn get(&self, path: &str, host: &str, extra: &str) -> (u32, String) {
        let mut stream = TcpStream::connect(&self.host).unwrap();
        write!(
            stream,
            "GET {path} HTTP/1.1\r\nHost: {host}\r\n{extra}Connection: close\r\n\r\n"
        )
        .unwrap();
        let mut response = String::new();
        stream.read_to_string(&mut response).unwrap();
        let status = response[9..12].parse().unwrap();
        let body = response.split_once("\r\n\r\n").unwrap().1.to_string();
        (status, body)
    }
}

impl Drop for View {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn serves_the_page_and_the_camera_and_nothing_else() {
    let view = View::start(&["spheres", "--width", "64"]);
    let host = view.host.clone();
    assert!(host.starts_with("127.0.0.1:"), "{host}");
    let (status, page) = view.get("/", &host, "");
    assert_eq!(status, 200);
    assert!(page.contains("<title>spheres · raytracer view</title>"));
    assert!(page.contains("new WebSocket("));
    // Nothing is fetched from elsewhere: no absolute URL in the page.
    assert!(!page.contains("https://") && !page.contains("src=\"http"));
    let (status, table) = view.get("/camera.toml", &host, "");
    assert_eq!(status, 200);
    assert!(
        table.starts_with("[camera]\nwidth = 64\naspect_ratio = \"16:9\"\n"),
        "{table}"
    );
    let port = host.split(':').nth(1).unwrap();
    let localhost = format!("localhost:{port}");
    assert_eq!(view.get("/camera.toml", &localhost, "").0, 200);
    // Other routes, host names and origins.
    assert_eq!(view.get("/index.html", &host, "").0, 404);
    assert_eq!(view.get("/../Cargo.toml", &host, "").0, 404);
    let elsewhere = format!("attacker.example:{port}");
    assert_eq!(view.get("/", &elsewhere, "").0, 403);
    assert_eq!(view.get("/camera.toml", "", "").0, 403);
    let origin = "Origin: http://attacker.example\r\n";
    assert_eq!(view.get("/camera.toml", &host, origin).0, 403);
    let own = format!("Origin: http://{host}\r\n");
    assert_eq!(view.get("/camera.toml", &host, &own).0, 200);
}

#[test]
fn a_taken_port_or_a_bad_scene_is_an_error() {
    let view = View::start(&["spheres", "--width", "16"]);
    let port = view.host.split(':').nth(1).unwrap();
    let out = Command::new(BIN)
        .args(["view", "spheres", "--port", port])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--port"), "{stderr}");
    assert!(out.stdout.is_empty());

    let out = Command::new(BIN)
        .args(["view", "no-such-scene", "--port", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-such-scene"));
    let out = Command::new(BIN)
        .args(["view", "spheres", "--listen", "nowhere"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--listen"));
}
