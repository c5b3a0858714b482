//! Live event streams over TCP in DV's AEDAT 4.0 network framing: reading what iniVation's DV
//! software or dv-processing's `NetworkWriter` serves (`tcp://HOST:PORT`, [`connect`]), and
//! serving an event file at its recorded pace as a stand-in sensor ([`serve`]).
//!
//! The protocol, as dv-processing 2.0 sends it to each client on connecting: a little-endian
//! `u32` length and the `IOHeader` FlatBuffer (compression, an XML description of the stream),
//! then packets, each a `u32` stream id, a `u32` size and a size-prefixed FlatBuffer (`EVTS`),
//! compressed as the header says. It is the AEDAT 4.0 file layout without the magic and without a
//! table of packets; the stream ends when the sender closes the connection.

use super::aedat4::{Compression, Decoder, Encoder, EncoderOptions};
use super::{EventSource, OpenOptions};
use crate::error::{Error, Result};
use crate::event::{Event, Resolution};
use std::io::{BufReader, BufWriter, Read};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How a live stream is named on the command line: `tcp://HOST:PORT`.
pub const SCHEME: &str = "tcp://";

/// The `HOST:PORT` of a `tcp://HOST:PORT` name, or `None` for anything else (a file).
pub fn tcp_address(name: &str) -> Option<&str> {
    name.strip_prefix(SCHEME)
}

/// How long a client waits: to connect, and for the next bytes of an open stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConnectOptions {
    pub connect_timeout: Duration,
    /// A sender that sends nothing for this long has stalled: the read ends with an error that
    /// says so (the words read until then are kept by the reader). `None` waits forever.
    pub stall_timeout: Option<Duration>,
}

impl Default for ConnectOptions {
    fn default() -> Self {
        Self { connect_timeout: Duration::from_secs(10), stall_timeout: Some(Duration::from_secs(10)) }
    }
}

/// A live AEDAT 4.0 stream read from a TCP connection.
pub type TcpSource = Decoder<BufReader<Stalls>>;

/// A socket whose read timeout reads as "the sender stalled" in errors.
pub struct Stalls {
    stream: TcpStream,
    after: Option<Duration>,
}

impl Read for Stalls {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.stream.read(buf).map_err(|e| match e.kind() {
            std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut => std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                format!("the sender stalled: no bytes for {:.1} s", self.after.unwrap_or_default().as_secs_f64()),
            ),
            _ => e,
        })
    }
}

/// Connects to the AEDAT 4.0 network stream at `address` (`HOST:PORT`) and reads its header.
/// Errors name the stream `tcp://HOST:PORT` and, past the header, the byte of the stream.
pub fn connect(address: &str, options: &OpenOptions, net: &ConnectOptions) -> Result<TcpSource> {
    let name = PathBuf::from(format!("{SCHEME}{address}"));
    let io = |e: std::io::Error| Error::Io { path: name.clone(), source: e };
    let addrs: Vec<SocketAddr> = address.to_socket_addrs().map_err(io)?.collect();
    let mut last = None;
    let mut stream = None;
    for a in &addrs {
        match TcpStream::connect_timeout(a, net.connect_timeout) {
            Ok(s) => {
                stream = Some(s);
                break;
            }
            Err(e) => last = Some(e),
        }
    }
    let stream = stream.ok_or_else(|| {
        io(last.unwrap_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "the address resolves to nothing")))
    })?;
    stream.set_nodelay(true).map_err(io)?;
    stream.set_read_timeout(net.stall_timeout).map_err(io)?;
    let reader = BufReader::with_capacity(1 << 16, Stalls { stream, after: net.stall_timeout });
    Decoder::from_network(reader, &name, options)
}

/// How [`serve`] sends a file.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayOptions {
    /// Stream time per wall time: 1 sends at the recorded pace, 2 twice as fast, 0 as fast as the
    /// client reads.
    pub pace: f64,
    /// The longest stretch of stream time one packet holds (DV's cameras send a packet per
    /// readout, about a millisecond).
    pub packet_us: i64,
    pub compression: Compression,
    /// After the last packet, how long to keep the connection open for the client to close it
    /// first: dv-processing's `NetworkReader` drops the packets it has not yet handed out when
    /// the sender closes. Zero closes at once (the end of the stream for `braille read`).
    pub linger: Duration,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        Self { pace: 1.0, packet_us: 1000, compression: Compression::None, linger: Duration::ZERO }
    }
}

/// What serving one client sent.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ReplayStats {
    pub client: String,
    pub events: u64,
    pub packets: u64,
    /// Stream time from the first event to the last, and the wall time sending took.
    pub stream_s: f64,
    pub wall_s: f64,
    /// How far behind its due time the latest packet went out (pacing's worst lag), in ms.
    pub max_lag_ms: f64,
}

/// The line `braille replay` prints per client.
impl std::fmt::Display for ReplayStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "sent {} events in {} packets ({:.2} s of stream) to {} in {:.2} s; latest packet {:.1} ms behind its time",
            self.events, self.packets, self.stream_s, self.client, self.wall_s, self.max_lag_ms
        )
    }
}

/// Waits for one client on `listener` and sends it every event of `source` in DV's network
/// framing, each packet when its last event is due at `options.pace`, then closes the connection.
pub fn serve(
    listener: &TcpListener,
    source: &mut dyn EventSource,
    resolution: Resolution,
    options: &ReplayOptions,
) -> Result<ReplayStats> {
    if !(options.pace >= 0.0 && options.pace.is_finite()) {
        return Err(Error::config("pace", format!("must be 0 (no pacing) or positive, not {}", options.pace)));
    }
    if options.packet_us < 1 {
        return Err(Error::config("packet_us", "must be at least 1 us"));
    }
    let listen_name = PathBuf::from(format!("{SCHEME}{}", listener.local_addr().map_or("?".into(), |a| a.to_string())));
    let (stream, client) = listener.accept().map_err(|e| Error::Io { path: listen_name.clone(), source: e })?;
    stream.set_nodelay(true).map_err(|e| Error::Io { path: listen_name.clone(), source: e })?;
    let client_name = PathBuf::from(format!("{SCHEME}{client}"));
    let encoder_options =
        EncoderOptions { compression: options.compression, packet_events: 1 << 16, source: "braille replay".into() };
    let mut out = Encoder::to_network(
        BufWriter::with_capacity(1 << 16, stream),
        &client_name,
        Some(resolution),
        encoder_options,
    )?;
    out.flush()?;
    // the pace's clock starts with the first events, however long the source took to give them
    let mut started = Instant::now();
    let (mut first, mut last) = (None::<i64>, 0i64);
    let (mut events, mut packets, mut max_lag) = (0u64, 0u64, Duration::ZERO);
    let mut packet: Vec<Event> = Vec::new();
    let mut send =
        |packet: &mut Vec<Event>, out: &mut Encoder<BufWriter<TcpStream>>, t0: i64, started: Instant| -> Result<()> {
            let Some(end) = packet.last().map(|e| e.t_us) else { return Ok(()) };
            if options.pace > 0.0 {
                let due = started + Duration::from_secs_f64((end - t0) as f64 / 1e6 / options.pace);
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                } else {
                    max_lag = max_lag.max(now - due);
                }
            }
            out.write(packet)?;
            out.flush()?;
            events += packet.len() as u64;
            packets += 1;
            packet.clear();
            Ok(())
        };
    while let Some(chunk) = source.next_chunk()? {
        if first.is_none() {
            started = Instant::now();
        }
        let t0 = *first.get_or_insert(chunk[0].t_us);
        for e in chunk {
            if packet.first().is_some_and(|p| e.t_us - p.t_us >= options.packet_us) {
                send(&mut packet, &mut out, t0, started)?;
            }
            packet.push(*e);
        }
        last = chunk[chunk.len() - 1].t_us;
    }
    send(&mut packet, &mut out, first.unwrap_or(0), started)?;
    let stream =
        out.into_inner()?.into_inner().map_err(|e| Error::Io { path: client_name.clone(), source: e.into_error() })?;
    if !options.linger.is_zero() {
        // until the client closes (a read of 0 bytes or an error) or the linger passes
        let mut stream = &stream;
        stream.set_read_timeout(Some(options.linger)).ok();
        let mut sink = [0u8; 4096];
        let until = Instant::now() + options.linger;
        while Instant::now() < until && matches!(stream.read(&mut sink), Ok(n) if n > 0) {}
    }
    // the client reads to the end of the stream; a clean close is its end
    stream.shutdown(std::net::Shutdown::Write).ok();
    Ok(ReplayStats {
        client: client.to_string(),
        events,
        packets,
        stream_s: first.map_or(0.0, |f| (last - f) as f64 / 1e6),
        wall_s: started.elapsed().as_secs_f64(),
        max_lag_ms: max_lag.as_secs_f64() * 1e3,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::Polarity;
    use std::path::Path;

    fn events(n: usize, step_us: i64) -> Vec<Event> {
        (0..n)
            .map(|i| Event {
                t_us: 1_000 + i as i64 * step_us,
                x: (i % 64) as u16,
                y: (i / 64 % 48) as u16,
                polarity: Polarity::from_on(i % 3 == 0),
            })
            .collect()
    }

    /// A source over events in memory.
    struct Mem {
        events: Vec<Event>,
        done: bool,
        info: super::super::StreamInfo,
    }

    impl EventSource for Mem {
        fn info(&self) -> &super::super::StreamInfo {
            &self.info
        }
        fn next_chunk(&mut self) -> Result<Option<&[Event]>> {
            if std::mem::replace(&mut self.done, true) { Ok(None) } else { Ok(Some(&self.events)) }
        }
        fn path(&self) -> &Path {
            Path::new("memory")
        }
    }

    fn mem(events: Vec<Event>) -> Mem {
        Mem {
            events,
            done: false,
            info: super::super::StreamInfo { format: super::super::Format::Aedat4, resolution: None, source: None },
        }
    }

    fn read_all(mut s: TcpSource) -> Result<Vec<Event>> {
        let mut got = Vec::new();
        while let Some(c) = s.next_chunk()? {
            got.extend_from_slice(c);
        }
        Ok(got)
    }

    #[test]
    fn a_served_stream_reads_back_event_for_event_in_packets_of_a_millisecond() {
        let sent = events(5000, 7); // 35 ms of stream
        for compression in [Compression::None, Compression::Lz4, Compression::Zstd] {
            let listener = TcpListener::bind("127.0.0.1:0").unwrap();
            let address = listener.local_addr().unwrap().to_string();
            let mut source = mem(sent.clone());
            let opts = ReplayOptions { pace: 0.0, packet_us: 1000, compression, ..Default::default() };
            let server =
                std::thread::spawn(move || serve(&listener, &mut source, Resolution::new(64, 48), &opts).unwrap());
            let client = connect(&address, &OpenOptions::default(), &ConnectOptions::default()).unwrap();
            assert_eq!(client.info().resolution, Some(Resolution::new(64, 48)));
            assert_eq!(read_all(client).unwrap(), sent, "{compression:?}");
            let stats = server.join().unwrap();
            assert_eq!(stats.events, 5000);
            // 7 us apart, 1000 us per packet: 143 events a packet, 35 packets
            assert_eq!(stats.packets, 5000_u64.div_ceil(143));
        }
    }

    #[test]
    fn pacing_sends_at_the_recorded_pace() {
        let sent = events(201, 1000); // 200 ms of stream
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap().to_string();
        let mut source = mem(sent.clone());
        let server = std::thread::spawn(move || {
            serve(&listener, &mut source, Resolution::new(64, 48), &ReplayOptions::default()).unwrap()
        });
        let got = read_all(connect(&address, &OpenOptions::default(), &ConnectOptions::default()).unwrap()).unwrap();
        assert_eq!(got, sent);
        let stats = server.join().unwrap();
        assert!((stats.stream_s - 0.2).abs() < 1e-9);
        // never early; late by no more than the machine's scheduling
        assert!(stats.wall_s >= 0.2, "{stats:?}");
    }

    /// A raw server that sends `bytes` and then either closes or stalls.
    fn raw_server(bytes: Vec<u8>, stall: bool) -> String {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap().to_string();
        std::thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            std::io::Write::write_all(&mut s, &bytes).unwrap();
            if stall {
                std::thread::sleep(Duration::from_secs(3));
            }
        });
        address
    }

    /// The bytes a served stream of `sent` starts with: the header and its packets.
    fn stream_bytes(sent: &[Event]) -> Vec<u8> {
        let mut enc = Encoder::to_network(
            Vec::new(),
            Path::new("memory"),
            Some(Resolution::new(64, 48)),
            EncoderOptions { compression: Compression::None, packet_events: 100, source: "test".into() },
        )
        .unwrap();
        enc.write(sent).unwrap();
        enc.into_inner().unwrap()
    }

    #[test]
    fn a_stalled_truncated_or_garbled_sender_gets_a_clear_error_after_the_events_it_sent() {
        let sent = events(300, 10);
        let bytes = stream_bytes(&sent);
        let quick = ConnectOptions { stall_timeout: Some(Duration::from_millis(300)), ..Default::default() };
        let read = |address: String| -> (Vec<Event>, String) {
            let mut s = connect(&address, &OpenOptions::default(), &quick).unwrap();
            let mut got = Vec::new();
            loop {
                match s.next_chunk() {
                    Ok(Some(c)) => got.extend_from_slice(c),
                    Ok(None) => return (got, String::new()),
                    Err(e) => return (got, e.to_string()),
                }
            }
        };
        // stalls after the whole stream: the events arrive, then the stall is named
        let (got, err) = read(raw_server(bytes.clone(), true));
        assert_eq!(got, sent);
        assert!(err.contains("stalled") && err.starts_with(&format!("{SCHEME}127.0.0.1:")), "{err}");
        // closes halfway into the last packet: the first two packets arrive, then the truncation
        let cut = bytes.len() - 500;
        let (got, err) = read(raw_server(bytes[..cut].to_vec(), false));
        assert_eq!(got, sent[..200]);
        assert!(err.contains("truncated at byte"), "{err}");
        // garbage after the header
        let header_len = 4 + u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
        let mut garbled = bytes[..header_len].to_vec();
        garbled.extend_from_slice(&[0, 0, 0, 0, 16, 0, 0, 0]);
        garbled.extend_from_slice(b"not a flatbuffer");
        let (got, err) = read(raw_server(garbled, false));
        assert!(got.is_empty());
        assert!(err.contains(&format!("at byte {header_len}")) && err.contains("event packet"), "{err}");
        // nothing at all
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap().to_string();
        drop(listener);
        let err = connect(&address, &OpenOptions::default(), &quick).err().unwrap().to_string();
        assert!(err.starts_with(&format!("{SCHEME}{address}")), "{err}");
    }

    #[test]
    fn only_tcp_names_are_addresses() {
        assert_eq!(tcp_address("tcp://127.0.0.1:7777"), Some("127.0.0.1:7777"));
        assert_eq!(tcp_address("scan.aedat4"), None);
        assert_eq!(tcp_address("-"), None);
    }
}
