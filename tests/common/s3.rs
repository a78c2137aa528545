//! A loopback S3 server for the object-storage tests: moto's server (PyPI `moto[server]`),
//! started by the test on a free port and killed when the test ends. Buckets and objects
//! are set up with boto3 (installed with moto), not with heatrun's own client.

use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A running moto server.
pub struct S3Server {
    child: Child,
    /// Its endpoint, `http://127.0.0.1:PORT`.
    pub endpoint: String,
}

impl S3Server {
    /// Starts a server, or — where `moto_server` is not installed — prints why the test
    /// is skipped and gives `None`; with `HEATRUN_REQUIRE_S3=1` (as `.ci/run` sets) a
    /// missing server fails the test instead.
    pub fn start() -> Option<S3Server> {
        let port = free_port();
        let child = match Command::new("moto_server")
            .args(["-H", "127.0.0.1", "-p", &port.to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
        {
            Ok(child) => child,
            Err(e) => {
                assert!(
                    std::env::var_os("HEATRUN_REQUIRE_S3").is_none(),
                    "HEATRUN_REQUIRE_S3 is set but moto_server cannot start: {e}"
                );
                eprintln!("note: S3 test skipped: moto_server not found ({e}); pip install \"moto[server]\"");
                return None;
            }
        };
        let server = S3Server {
            child,
            endpoint: format!("http://127.0.0.1:{port}"),
        };
        let started = Instant::now();
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                started.elapsed() < Duration::from_secs(60),
                "moto_server did not listen on port {port} within 60 s"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        Some(server)
    }

    /// The environment a client of this server needs (any key and secret do).
    pub fn env(&self) -> Vec<(&'static str, String)> {
        vec![
            ("AWS_ENDPOINT_URL", self.endpoint.clone()),
            ("AWS_ALLOW_HTTP", "true".into()),
            ("AWS_ACCESS_KEY_ID", "testing".into()),
            ("AWS_SECRET_ACCESS_KEY", "testing".into()),
            ("AWS_REGION", "us-east-1".into()),
        ]
    }

    /// Runs a boto3 snippet against the server (`s3` is the client), failing on error;
    /// returns its stdout.
    pub fn boto3(&self, code: &str) -> String {
        let script = format!(
            "import boto3\ns3 = boto3.client('s3', endpoint_url='{}', region_name='us-east-1', \
             aws_access_key_id='testing', aws_secret_access_key='testing')\n{code}\n",
            self.endpoint
        );
        let out = Command::new("python3")
            .args(["-c", &script])
            .output()
            .expect("python3 runs");
        assert!(
            out.status.success(),
            "boto3 failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// Uploads a local file as `s3://bucket/key`.
    pub fn upload(&self, file: &Path, bucket: &str, key: &str) {
        self.boto3(&format!(
            "s3.upload_file({:?}, {bucket:?}, {key:?})",
            file.display().to_string()
        ));
    }

    /// An object's bytes.
    pub fn download(&self, bucket: &str, key: &str, to: &Path) {
        self.boto3(&format!(
            "s3.download_file({bucket:?}, {key:?}, {:?})",
            to.display().to_string()
        ));
    }

    /// Runs the heatrun binary with this server's environment.
    pub fn heatrun(&self, args: &[&str], cwd: &Path) -> std::process::Output {
        Command::new(env!("CARGO_BIN_EXE_heatrun"))
            .args(args)
            .envs(self.env())
            .current_dir(cwd)
            .output()
            .expect("heatrun runs")
    }
}

impl Drop for S3Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A port free on loopback now (the OS's pick for port 0).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port on loopback")
}
