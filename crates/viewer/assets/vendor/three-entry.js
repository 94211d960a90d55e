// The parts of three.js the octoarm viewer uses (bundled and minified with esbuild).
export {
  AmbientLight, ArrowHelper, AxesHelper, BufferAttribute, BufferGeometry, Color, CylinderGeometry,
  DirectionalLight, DoubleSide, Float32BufferAttribute, GridHelper, Group, HemisphereLight, Line,
  LineBasicMaterial, LineSegments, Matrix4, Mesh, MeshBasicMaterial, MeshPhongMaterial,
  MeshStandardMaterial, OrthographicCamera, PerspectiveCamera, PlaneGeometry, Quaternion, Scene,
  SphereGeometry, Vector3, WebGLRenderer, CircleGeometry, RingGeometry,
} from 'three';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
