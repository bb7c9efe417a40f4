// Serves a folder on 127.0.0.1 with HTTP Range support (Potree fetches each node's slice of
// octree.bin by range). With a results path, a page may POST /result (JSON) and /screenshot
// (a PNG data URL); the server writes them to <results> and <results>.png and exits after
// the result.
//   node server.js ROOT [PORT (0: any)] [RESULTS]      prints the port it listens on
const http = require('http'), fs = require('fs'), path = require('path');
const root = path.resolve(process.argv[2]);
const results = process.argv[4];
const types = {'.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json'};

function receive (req, res) {
  const chunks = [];
  req.on('data', c => chunks.push(c));
  req.on('end', () => {
    const body = Buffer.concat(chunks).toString();
    const name = new URL(req.url, 'http://localhost').pathname.slice(1);
    if (name === 'screenshot')
      fs.writeFileSync(results + '.png', Buffer.from(body.replace(/^data:image\/png;base64,/, ''), 'base64'));
    else
      fs.writeFileSync(results, body);
    res.writeHead(204);
    res.end();
    if (name === 'result')
      setTimeout(() => process.exit(0), 100);
  });
}

function serve (req, res) {
  const file = path.join(root, decodeURIComponent(new URL(req.url, 'http://localhost').pathname));
  if (!file.startsWith(root) || !fs.existsSync(file) || fs.statSync(file).isDirectory()) {
    res.writeHead(404);
    res.end();
    return;
  }
  const size = fs.statSync(file).size;
  const type = types[path.extname(file)] || 'application/octet-stream';
  const range = /bytes=(\d+)-(\d*)/.exec(req.headers.range || '');
  if (!range) {
    res.writeHead(200, {'Content-Type': type, 'Content-Length': size, 'Accept-Ranges': 'bytes'});
    fs.createReadStream(file).pipe(res);
    return;
  }
  const start = +range[1], end = range[2] ? Math.min(+range[2], size - 1) : size - 1;
  if (start > end) {
    res.writeHead(416, {'Content-Range': `bytes */${size}`});
    res.end();
    return;
  }
  res.writeHead(206, {'Content-Type': type, 'Content-Length': end - start + 1,
                      'Content-Range': `bytes ${start}-${end}/${size}`, 'Accept-Ranges': 'bytes'});
  fs.createReadStream(file, {start, end}).pipe(res);
}

const server = http.createServer((req, res) => (req.method === 'POST' && results ? receive : serve)(req, res));
server.listen(+(process.argv[3] || 0), '127.0.0.1', () => console.log(server.address().port));
