//! Live preview in the tev viewer (`--display-server HOST:PORT`, as pbrt-v4's `--display-server`):
//! the image is sent as it converges over tev's TCP protocol — a CreateImage packet, then
//! UpdateImage (version 3) packets of horizontal bands, interleaved RGB floats. Each packet is its
//! length (u32, itself included), a type byte and little-endian fields, strings NUL-terminated.

use caustica::film::Image;
use std::io::Write;
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// tev's packet types that are sent.
const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE_V3: u8 = 6;
/// Rows per update packet: bands of at most a few MB.
const BAND_ROWS: u32 = 64;
/// Least time between two updates: tev redraws each, and the render should not wait on the viewer.
const MIN_INTERVAL: Duration = Duration::from_millis(500);

/// A connection to a tev viewer showing one image.
pub struct DisplayServer {
    stream: TcpStream,
    name: String,
    last: Option<Instant>,
}

/// One packet being written.
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Self {
        let mut bytes = vec![0; 4];
        bytes.push(kind);
        Self(bytes)
    }

    fn byte(mut self, b: u8) -> Self {
        self.0.push(b);
        self
    }

    fn string(mut self, s: &str) -> Self {
        self.0.extend_from_slice(s.as_bytes());
        self.0.push(0);
        self
    }

    fn i32(mut self, v: i32) -> Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    fn i64(mut self, v: i64) -> Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    fn floats(mut self, values: impl Iterator<Item = f32>) -> Self {
        for v in values {
            self.0.extend_from_slice(&v.to_le_bytes());
        }
        self
    }

    fn finish(mut self) -> Vec<u8> {
        let size = self.0.len() as u32;
        self.0[..4].copy_from_slice(&size.to_le_bytes());
        self.0
    }
}

impl DisplayServer {
    /// Connect to tev at `address` and create the image `name` of `width` × `height` there.
    pub fn connect(address: &str, name: &str, width: u32, height: u32) -> std::io::Result<Self> {
        let mut stream = TcpStream::connect(address)?;
        stream.set_nodelay(true)?;
        let mut create =
            Packet::new(CREATE_IMAGE).byte(0).string(name).i32(width as i32).i32(height as i32).i32(3);
        for channel in ["R", "G", "B"] {
            create = create.string(channel);
        }
        stream.write_all(&create.finish())?;
        Ok(Self { stream, name: name.to_owned(), last: None })
    }

    /// Whether an update is due: none was sent in the last half second.
    pub fn due(&self) -> bool {
        self.last.is_none_or(|t| t.elapsed() >= MIN_INTERVAL)
    }

    /// Send `image`.
    pub fn update(&mut self, image: &Image) -> std::io::Result<()> {
        self.last = Some(Instant::now());
        for y in (0..image.height).step_by(BAND_ROWS as usize) {
            let rows = BAND_ROWS.min(image.height - y);
            let mut packet = Packet::new(UPDATE_IMAGE_V3).byte(0).string(&self.name).i32(3);
            for channel in ["R", "G", "B"] {
                packet = packet.string(channel);
            }
            packet = packet.i32(0).i32(y as i32).i32(image.width as i32).i32(rows as i32);
            // Interleaved RGB: channel c at offset c, stride 3.
            packet = packet.i64(0).i64(1).i64(2).i64(3).i64(3).i64(3);
            let band = &image.pixels[(y * image.width) as usize..((y + rows) * image.width) as usize];
            let packet = packet.floats(band.iter().flat_map(|p| p.to_array()));
            self.stream.write_all(&packet.finish())?;
        }
        Ok(())
    }
}
